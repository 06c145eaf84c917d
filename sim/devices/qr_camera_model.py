"""A simulated forward camera that sees the QR code a customer holds up.

A pinhole camera low on the robot, pitched up towards a person's chest. A person in the world
with a ``qr_payload`` holds a printed code (OpenCV's ``QRCodeEncoder``) at ``CODE_HEIGHT_M``;
when they are in the field of view it is drawn at the size the distance gives, slightly rotated
(a hand is never square to the lens, and it shakes), on a plain background, then blurred and
noised like a cheap USB sensor. Everything else is background: the frame is for the real QR
decoder, not for a person to look at. Walls do not hide people here (the mission only asks for
a code from the customer the robot stands in front of).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np
import numpy.typing as npt

from sim.devices.frame_source import FrameSource
from sim.world.body import DiffDriveBody
from sim.world.floor_plan import World
from sim.world.geometry import Pose, wrap_angle

U8Image = npt.NDArray[Any]

CODE_HEIGHT_M = 0.8
"""Where a customer holds the code out to a robot this small: about waist height."""
_PAPER, _INK = 225.0, 35.0  # grey levels of the code's white and black under room light


@dataclass(frozen=True, slots=True)
class ForwardMount:
    """The forward camera: where it sits, where it looks, and its image defects."""

    width_px: int = 640
    height_px: int = 480
    fps: float = 10.0
    hfov_deg: float = 50.0  # a webcam with a slightly long lens: codes are small
    lens_height_m: float = 0.30
    pitch_deg: float = 40.0  # upwards: a code 0.4-1 m away is in the image
    code_side_m: float = 0.18  # a printed order slip, quiet zone included
    max_tilt_deg: float = 5.0  # rotation of the code in the image plane
    shake_deg: float = 1.0  # per-frame jitter of that rotation
    blur_sigma_px: float = 0.6  # focus and optics
    noise_std: float = 3.0  # grey levels
    background: float = 140.0

    @property
    def focal_px(self) -> float:
        return self.width_px / 2 / math.tan(math.radians(self.hfov_deg) / 2)


@dataclass(frozen=True, slots=True)
class _Held:
    payload: str
    x_m: float
    y_m: float
    tilt_deg: float


@dataclass(frozen=True, slots=True)
class _Shot:
    seq: int
    t_s: float
    pose: Pose
    held: tuple[_Held, ...]
    noise_at: tuple[int, int]
    shake_deg: float


QUIET_ZONE_MODULES = 4  # the standard's white margin; OpenCV's encoder leaves it out


def qr_image(payload: str) -> npt.NDArray[np.uint8]:
    """The code OpenCV's encoder makes for ``payload``, one pixel a module, with a quiet zone."""
    code = np.asarray(cv2.QRCodeEncoder.create().encode(payload), np.uint8)
    q = QUIET_ZONE_MODULES
    return np.asarray(cv2.copyMakeBorder(code, q, q, q, q, cv2.BORDER_CONSTANT, value=255),
                      np.uint8)


class SimQrCamera(FrameSource[_Shot]):
    """A `hal.devices.Camera` looking forward from the robot's body at people's QR codes."""

    def __init__(self, world: World, body: DiffDriveBody, mount: ForwardMount | None = None,
                 *, seed: int = 1, name: str = "qr_camera") -> None:
        self.mount = mount or ForwardMount()
        super().__init__(self.mount.fps)
        self.name = name
        self.world = world
        self.body = body
        self.width_px = self.mount.width_px
        self.height_px = self.mount.height_px
        self._rng = np.random.default_rng(seed)
        self._noise = np.clip(np.rint(self._rng.normal(
            0.0, self.mount.noise_std, (2 * self.height_px, 2 * self.width_px))),
            -127, 127).astype(np.int8)
        self._codes: dict[str, npt.NDArray[np.uint8]] = {}
        self._tilts: dict[str, float] = {}

    def render(self, pose: Pose) -> U8Image:
        """What the camera sees from ``pose`` now (fresh noise and shake), without the clock."""
        return self._render(self._shot_from(0, 0.0, pose))

    def code_px(self, distance_m: float) -> float:
        """Side of a held code in the image at ``distance_m`` (floor distance) from the lens."""
        dh = CODE_HEIGHT_M - self.mount.lens_height_m
        return self.mount.focal_px * self.mount.code_side_m / math.hypot(distance_m, dh)

    # --- FrameSource ---------------------------------------------------------------------------
    def _snapshot(self, seq: int, t_s: float) -> _Shot:
        return self._shot_from(seq, t_s, self.body.pose)

    def _draw(self, shot: _Shot) -> U8Image:
        return self._render(shot)

    # --- internals ----------------------------------------------------------------------------
    def _shot_from(self, seq: int, t_s: float, pose: Pose) -> _Shot:
        held = []
        for person in self.world.people:
            payload = person.qr_payload
            if person.present and payload:
                if payload not in self._tilts:
                    self._tilts[payload] = float(self._rng.uniform(-1, 1)) * self.mount.max_tilt_deg
                held.append(_Held(payload, person.x_m, person.y_m, self._tilts[payload]))
        held.sort(key=lambda h: -pose.distance_to(h.x_m, h.y_m))  # far first: near ones cover
        noise_at = (int(self._rng.integers(0, self.height_px)),
                    int(self._rng.integers(0, self.width_px)))
        shake = float(self._rng.normal(0.0, self.mount.shake_deg))
        return _Shot(seq, t_s, pose, tuple(held), noise_at, shake)

    def _render(self, shot: _Shot) -> U8Image:
        m = self.mount
        image = np.full((m.height_px, m.width_px), m.background, np.float32)
        for held in shot.held:
            self._draw_code(image, shot.pose, held, shot.shake_deg)
        if m.blur_sigma_px > 0:
            image = np.asarray(cv2.GaussianBlur(image, (0, 0), m.blur_sigma_px), np.float32)
        r, c = shot.noise_at
        image += self._noise[r:r + m.height_px, c:c + m.width_px]
        grey = np.clip(image, 0, 255).astype(np.uint8)
        return np.asarray(cv2.cvtColor(grey, cv2.COLOR_GRAY2BGR))

    def _draw_code(self, image: npt.NDArray[np.float32], pose: Pose, held: _Held,
                   shake_deg: float) -> None:
        m = self.mount
        dx, dy = held.x_m - pose.x_m, held.y_m - pose.y_m
        bearing = wrap_angle(math.atan2(dy, dx) - pose.heading_rad)
        forward_m = math.hypot(dx, dy) * math.cos(bearing)
        if forward_m < 0.15 or abs(bearing) > math.radians(m.hfov_deg) / 2:
            return
        f = m.focal_px
        col = m.width_px / 2 - f * math.tan(bearing)
        elevation = math.atan2(CODE_HEIGHT_M - m.lens_height_m, forward_m) - math.radians(
            m.pitch_deg)
        row = m.height_px / 2 - f * math.tan(elevation)
        side_px = self.code_px(forward_m)
        code = self._codes.get(held.payload)
        if code is None:
            code = self._codes[held.payload] = qr_image(held.payload)
        if side_px < 4 or not (-side_px < col < m.width_px + side_px
                               and -side_px < row < m.height_px + side_px):
            return
        card = np.where(code > 127, _PAPER, _INK).astype(np.float32)
        _paste_card(image, card, col, row, side_px, held.tilt_deg + shake_deg)


_SUPERSAMPLE = 4
"""The card is drawn at 4x with nearest-neighbour and averaged down: module edges then fall
between pixels as a lens renders them. (Bilinear upscaling smears every edge over the whole
module, and OpenCV's decoder then fails codes a camera would read.)"""


def _paste_card(image: npt.NDArray[np.float32], card: npt.NDArray[np.float32], col: float,
                row: float, side_px: float, angle_deg: float) -> None:
    """Draw ``card`` centred at (col, row), ``side_px`` wide, turned by ``angle_deg``."""
    k = _SUPERSAMPLE
    n = card.shape[0]
    patch_px = math.ceil(side_px * 1.5) + 2  # room for any rotation
    left, top = round(col - patch_px / 2), round(row - patch_px / 2)
    matrix = cv2.getRotationMatrix2D((n / 2, n / 2), angle_deg, side_px * k / n)
    matrix[0, 2] += (col - left) * k - n / 2
    matrix[1, 2] += (row - top) * k - n / 2
    size = (patch_px * k, patch_px * k)
    big = cv2.warpAffine(card, matrix, size, flags=cv2.INTER_NEAREST, borderValue=0.0)
    mask = cv2.warpAffine(np.ones_like(card), matrix, size, flags=cv2.INTER_NEAREST,
                          borderValue=0.0)
    ink = cv2.resize(big, (patch_px, patch_px), interpolation=cv2.INTER_AREA)
    cover = cv2.resize(mask, (patch_px, patch_px), interpolation=cv2.INTER_AREA)
    h, w = image.shape
    r0, c0 = max(top, 0), max(left, 0)
    r1, c1 = min(top + patch_px, h), min(left + patch_px, w)
    if r0 >= r1 or c0 >= c1:
        return
    pr, pc = slice(r0 - top, r1 - top), slice(c0 - left, c1 - left)
    region = image[r0:r1, c0:c1]
    region *= 1.0 - cover[pr, pc]
    region += ink[pr, pc]
