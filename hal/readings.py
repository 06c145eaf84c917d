"""Readings that devices deliver: plain frozen dataclasses (a camera's Frame may draw itself on
demand), timestamps in event-loop seconds."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from enum import Enum
from typing import Protocol

import numpy as np
import numpy.typing as npt


@dataclass(frozen=True, slots=True)
class MotorCommand:
    """One `MOTOR` command: PWM duty 0-255 and direction per wheel (1 = forward)."""

    left_pwm: int
    right_pwm: int
    left_forward: bool = True
    right_forward: bool = True

    def __post_init__(self) -> None:
        if 0 <= self.left_pwm <= 255 and 0 <= self.right_pwm <= 255:
            return  # the usual case, twenty times a second: no loop, no getattr
        for name in ("left_pwm", "right_pwm"):
            value = getattr(self, name)
            if not 0 <= value <= 255:
                msg = f"{name} must be 0-255, got {value}"
                raise ValueError(msg)

    @classmethod
    def stopped(cls) -> MotorCommand:
        return cls(0, 0, True, True)

    @classmethod
    def from_signed(cls, left: float, right: float) -> MotorCommand:
        """Build from signed duties in [-1, 1] (negative = backwards)."""
        lpwm = round(min(1.0, abs(left)) * 255)
        rpwm = round(min(1.0, abs(right)) * 255)
        return cls(lpwm, rpwm, left >= 0, right >= 0)

    def signed(self) -> tuple[float, float]:
        """Signed duties in [-1, 1]."""
        left = self.left_pwm / 255 * (1 if self.left_forward else -1)
        right = self.right_pwm / 255 * (1 if self.right_forward else -1)
        return left, right

    @property
    def is_stop(self) -> bool:
        return self.left_pwm == 0 and self.right_pwm == 0


@dataclass(frozen=True, slots=True)
class EncoderReading:
    """Cumulative signed wheel encoder ticks."""

    left_ticks: int
    right_ticks: int
    t_s: float


@dataclass(frozen=True, slots=True)
class RangeReading:
    """A front distance sensor reading."""

    distance_cm: float
    t_s: float


@dataclass(frozen=True, slots=True)
class BatteryReading:
    voltage_v: float
    percent: float
    charging: bool
    on_dock_contacts: bool
    t_s: float


@dataclass(frozen=True, slots=True)
class DockSignal:
    """Strength of the dock's beams at the two front receivers: 10-bit ADC counts, 0-1023.

    From the motor board's ``IRS`` line (20 Hz); comparing left with right aligns the robot.
    """

    front_left: int
    front_right: int
    t_s: float


@dataclass(frozen=True, slots=True)
class DockContacts:
    """Voltage across the charging contacts in millivolts (0 off the dock).

    The board only measures; whether it is within the limits that count as docked is the
    behaviour's to judge (``docking`` settings).
    """

    mv: int
    t_s: float


@dataclass(frozen=True, slots=True)
class Bumpers:
    """The front bumper's two switches (True: pressed)."""

    left: bool
    right: bool
    t_s: float

    @property
    def any(self) -> bool:
        return self.left or self.right


@dataclass(frozen=True, slots=True)
class WallDistance:
    """The right-side wall sensor's distance."""

    distance_cm: float
    t_s: float


@dataclass(frozen=True, slots=True)
class BinLevel:
    """How full the dust bin is, 0-100 %."""

    percent: float
    t_s: float


class FramePainter(Protocol):
    """Draws one frame on demand (a simulated camera's shot): all of it or some of its rows."""

    @property
    def shape(self) -> tuple[int, int, int]:
        """(height, width, 3) of the image it draws."""
        ...

    def image(self) -> npt.NDArray[np.uint8]:
        """The whole BGR image."""
        ...

    def rows(self, indices: Sequence[int]) -> npt.NDArray[np.uint8]:
        """Rows ``indices`` of the image, (k, width, 3): the same bytes as ``image()[indices]``."""
        ...


class Frame:
    """A camera frame: ``image`` is the BGR uint8 image, shape (height, width, 3).

    A reader that needs only some rows asks ``rows(indices)``. A frame made with ``painted``
    draws on demand (a simulated camera's do): ``rows`` draws just the rows asked for, and the
    whole image is drawn once, the first time ``image`` is read.
    """

    __slots__ = ("_image", "_painter", "seq", "t_s")

    def __init__(self, image: npt.NDArray[np.uint8], seq: int, t_s: float) -> None:
        self._image: npt.NDArray[np.uint8] | None = image
        self._painter: FramePainter | None = None
        self.seq = seq
        self.t_s = t_s

    @classmethod
    def painted(cls, painter: FramePainter, seq: int, t_s: float) -> Frame:
        """A frame ``painter`` draws when it is looked at."""
        frame = cls.__new__(cls)
        frame._image = None
        frame._painter = painter
        frame.seq = seq
        frame.t_s = t_s
        return frame

    @property
    def image(self) -> npt.NDArray[np.uint8]:
        if self._image is None:
            assert self._painter is not None
            self._image = self._painter.image()
        return self._image

    @property
    def drawn(self) -> bool:
        """Whether the whole image is at hand (given, or drawn since)."""
        return self._image is not None

    @property
    def shape(self) -> tuple[int, ...]:
        """The image's shape, without drawing it."""
        if self._image is None and self._painter is not None:
            return self._painter.shape
        return tuple(self.image.shape)

    def rows(self, indices: Sequence[int]) -> npt.NDArray[np.uint8]:
        """Rows ``indices`` of the image, shape (k, width, 3): ``image[indices]``, drawn alone
        when the image has not been drawn."""
        if self._image is None and self._painter is not None:
            return self._painter.rows(indices)
        rows: npt.NDArray[np.uint8] = self.image[np.asarray(indices, np.intp)]
        return rows

    def __repr__(self) -> str:
        drawn = "drawn" if self.drawn else "not drawn"
        return f"Frame(seq={self.seq}, t_s={self.t_s}, shape={self.shape}, {drawn})"


@dataclass(frozen=True, slots=True)
class BeaconSighting:
    """One iBeacon advert as received: identity, RSSI and the advertised 1 m power."""

    mac: str
    uuid: str
    major: int
    minor: int
    rssi_dbm: int
    tx_power_dbm: int
    t_s: float


@dataclass(frozen=True, slots=True)
class WeightReading:
    kg: float
    raw: int
    t_s: float


@dataclass(frozen=True, slots=True)
class LidarScan:
    """One 360 degree scan in the robot's frame: x forward, y left, angles counter-clockwise.

    ``angles_rad`` (ascending, in [-pi, pi)) and ``ranges_m`` are measured from the robot's
    centre, the mount's yaw and offset already applied; a point with no return or out of the
    sensor's range has range NaN (``valid`` is False there) and the angle of its beam.
    ``origin_x_m``/``origin_y_m`` is where the sensor sits, for models that follow each ray.
    ``t_s`` is when the scan's last packet arrived (event-loop time).
    """

    angles_rad: npt.NDArray[np.float64]
    ranges_m: npt.NDArray[np.float64]
    intensities: npt.NDArray[np.uint8]
    t_s: float
    speed_dps: float = 0.0
    origin_x_m: float = 0.0
    origin_y_m: float = 0.0
    max_range_m: float = 12.0

    @property
    def valid(self) -> npt.NDArray[np.bool_]:
        """Which points had a return within range."""
        return np.isfinite(self.ranges_m)

    def points_xy(self) -> npt.NDArray[np.float64]:
        """The valid points as an (n, 2) array of x, y in metres (robot frame)."""
        valid = self.valid
        ranges, angles = self.ranges_m[valid], self.angles_rad[valid]
        return np.column_stack((ranges * np.cos(angles), ranges * np.sin(angles)))


@dataclass(frozen=True, slots=True)
class DockIrReading:
    """What each dock IR receiver saw over the last window (receiver name -> ...).

    ``codes``: the 8-bit beam codes decoded (known or not); ``beams``: the names the code
    table gives them (a combination code names each beam in it, e.g. red_buoy, green_buoy).
    A receiver that saw nothing has empty sets.
    """

    codes: dict[str, frozenset[int]] = field(default_factory=dict)
    beams: dict[str, frozenset[str]] = field(default_factory=dict)
    t_s: float = 0.0

    def sees(self, receiver: str, beam: str) -> bool:
        return beam in self.beams.get(receiver, frozenset())


class LedMode(Enum):
    IDLE = "LED_IDLE"
    WAITING = "LED_WAITING"
    MOVING = "LED_MOVING"
    SUCCESS_SCAN = "SUCCESS_SCAN"
    FAILURE_SCAN = "FAILURE_SCAN"


@dataclass(frozen=True, slots=True)
class LinkStats:
    """Statistics of a command link (the Arduino serial line)."""

    connected: bool
    sent: int = 0
    acked: int = 0
    resent: int = 0
    lost: int = 0
    dropped: int = 0
    crc_errors: int = 0
    nak: int = 0
    reconnects: int = 0
    rtt_p50_ms: float | None = None
    rtt_p99_ms: float | None = None
    firmware: str | None = None
