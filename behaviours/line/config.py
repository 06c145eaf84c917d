"""The ``line_follow`` config section, declared by the ``FollowConfig`` the follower reads."""

from __future__ import annotations

from dataclasses import dataclass, field

from behaviours.line.tracker import TrackerParams
from hal.options import Order, load, section_of, setting
from hal.settings import SettingsView


@dataclass(frozen=True, slots=True)
class FollowConfig:
    """The ``line_follow`` section, read once per change."""

    kp: float = setting(0.5, "Proportional gain.", min=0, max=100, tunable=True)
    ki: float = setting(0.0, "Integral gain.", min=0, max=100, tunable=True)
    kd: float = setting(0.1, "Derivative gain.", min=0, max=100, tunable=True)
    fps: float = setting(13.0, "Control loop rate (13 = the seed's 77 ms).", min=1, max=120,
                         tunable=True)
    band_forward_px: float = setting(30.0, "Below this error: straight on at full speed.",
                                     min=0, max=10000, tunable=True)
    band_gentle_px: float = setting(80.0, "Below this: gentle correction.",
                                    min=0, max=10000, tunable=True)
    band_strong_px: float = setting(150.0, "Below this: strong correction; above: full turn.",
                                    min=0, max=10000, tunable=True)
    speed: float = setting(0.55, "Wheel duty (0-1) when straight on.", min=0, max=1,
                           tunable=True)
    gentle_speed: float = setting(0.8, "Speed in the gentle band, fraction of speed.",
                                  min=0, max=1, tunable=True)
    strong_speed: float = setting(0.5, "Speed in the strong band, fraction of speed.",
                                  min=0, max=1, tunable=True)
    turn_speed: float = setting(0.4, "Wheel duty of a full turn and of the recovery turn.",
                                min=0, max=1, tunable=True)
    max_integral: float = setting(0.3, "Anti-windup: cap of the integral term (duty).",
                                  min=0, max=1, tunable=True)
    lost_frames: int = setting(20, "Frames without the line before stopping with an error.",
                               min=1, max=1000, tunable=True)
    colour: str = setting("black", "Line colour when the fleet server names none.",
                          choices=("black", "white", "red", "green", "blue", "yellow", "cyan",
                                   "magenta"), tunable=True)
    roi_top: float = setting(0.25, "Top of the scanned band, fraction of the image height.",
                             min=0, max=1, tunable=True)
    roi_bottom: float = setting(0.6, "Bottom of the scanned band (> roi_top).", min=0, max=1,
                                tunable=True)
    min_contrast: float = setting(0.2, "Contrast against the floor that counts as line.",
                                  min=0.01, max=1, tunable=True)
    bands_width_px: int = field(kw_only=True)
    """The frame width the bands are in pixels of (``camera.width``)."""

    @property
    def bands_px(self) -> tuple[float, float, float]:
        return self.band_forward_px, self.band_gentle_px, self.band_strong_px

    @property
    def tracker(self) -> TrackerParams:
        return TrackerParams(roi_top=self.roi_top, roi_bottom=self.roi_bottom,
                             min_contrast=self.min_contrast)

    @classmethod
    def from_settings(cls, settings: SettingsView) -> FollowConfig:
        """The section as it stands: the settings keep the bands rising and the ROI's top
        above its bottom (LINE_FOLLOW_ORDERS), in the file and in live tuning."""
        return load(cls, settings.section(LINE_FOLLOW.name),
                    bands_width_px=settings.get("camera.width"))


LINE_FOLLOW = section_of(FollowConfig, "line_follow", "Camera line following (seed 000 section 6).")

LINE_FOLLOW_ORDERS = (
    Order(("line_follow.band_forward_px", "line_follow.band_gentle_px",
           "line_follow.band_strong_px")),
    Order(("line_follow.roi_top", "line_follow.roi_bottom")),
)
