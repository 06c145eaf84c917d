"""Light and noise on the simulated camera's painted floor, for a whole frame or some of its rows.

The light reaching a pixel is the floor texture (fixed to the world) x the lens and LED falloff
(fixed to the image) x the room's patches of light and shade (fixed to the world, smooth);
the painted floor is multiplied by it and sensor noise added, by OpenCV calls a band of rows
at a time. (Until issue 26 a C pass did the same to the bit, and lit the tracker's rows alone;
the simulator's speed no longer pays for C that only it needs: docs/native.md.)
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, Protocol

import cv2
import numpy as np
import numpy.typing as npt

from sim.world.geometry import Pose

F32Array = npt.NDArray[Any]  # float32; cv2 returns loosely typed arrays
U8Image = npt.NDArray[Any]  # uint8 BGR
Affine = tuple[float, float, float, float, float, float]

TEXTURE_TILE_PX = 256
_AMBIENT_GRID = (8, 6)  # coarse grid the world-fixed light field is computed on
_BAND_ROWS = 32  # rows lit at a time: a band's float images fit in the CPU's cache
_DARK = 8.0  # what a covered lens sees, grey levels before noise


class Mount(Protocol):
    """What the light needs of the camera's mount (sim/devices/camera_model.CameraMount)."""

    @property
    def width_px(self) -> int: ...
    @property
    def height_px(self) -> int: ...
    @property
    def height_m(self) -> float: ...
    @property
    def forward_m(self) -> float: ...
    @property
    def m_per_px(self) -> float: ...
    @property
    def vignette(self) -> float: ...
    @property
    def light_gradient(self) -> float: ...
    @property
    def ambient_variation(self) -> float: ...

    def px_to_floor(self, pose: Pose, col: float, row: float) -> tuple[float, float]: ...


def make_texture(rng: np.random.Generator, texture_std: float, width_px: int,
                 height_px: int) -> tuple[F32Array, float]:
    """A seamless tile of floor texture, repeated so the whole view fits inside it, and the
    texture's centre (pixels).

    Reading inside one big periodic image is ten times faster than cv2's wrap-around border,
    and shifting by whole tiles is invisible, so the texture stays world-fixed.
    """
    n = TEXTURE_TILE_PX
    fine = rng.normal(0.0, 1.0, (n, n)).astype(np.float32)
    noise = np.tile(rng.normal(0.0, 1.0, (n, n)).astype(np.float32), (3, 3))
    blurred: F32Array = cv2.GaussianBlur(noise, (0, 0), 6)[n:2 * n, n:2 * n]
    blotches = blurred / max(float(blurred.std()), 1e-6)
    tile = 1.0 + texture_std * (0.6 * fine + 0.8 * blotches)
    reps = math.ceil(math.hypot(width_px, height_px) / n) + 2
    return np.tile(tile.astype(np.float32), (reps, reps)), reps * n / 2


class FloorLight:
    """Lights painted frames of one camera.

    Args:
        mount: the camera's mount (geometry and the light's parameters).
        texture: ``make_texture``'s texture and centre.
        noise: the sensor noise bank (int8, twice the frame's size), read at an offset a frame.
        phases: four phases (radians) of the room light's field.
    """

    def __init__(self, mount: Mount, texture: tuple[F32Array, float],
                 noise: npt.NDArray[np.int8], phases: npt.NDArray[np.float64]) -> None:
        self.mount = mount
        h, w = mount.height_px, mount.width_px
        self.texture, self._texture_centre = texture
        self.noise = noise
        self.static_gain = self._make_static_gain()
        gw, gh = _AMBIENT_GRID
        cc, rr = np.meshgrid(np.linspace(0, w - 1, gw), np.linspace(0, h - 1, gh))
        mpp = mount.m_per_px
        self._ambient_grid = (mount.forward_m + (h / 2 - rr - 0.5) * mpp,
                              (w / 2 - cc - 0.5) * mpp)
        self._phases = phases
        self._texture_buf = np.empty((h, w), np.float32)
        self._ambient_buf = np.empty((h, w), np.float32)
        self._gain_buf = np.empty((h, w), np.float32)
        self._gain3 = np.empty((_BAND_ROWS, w, 3), np.float32)
        self._lit = np.empty((_BAND_ROWS, w, 3), np.float32)
        self._affine: tuple[Pose, Affine] | None = None
        self._texture_pose: Pose | None = None
        self._ambient_pose: Pose | None = None
        self._gain_pose: Pose | None = None

    # --- lighting -----------------------------------------------------------------------------
    def light(self, paint: U8Image, pose: Pose, noise_at: tuple[int, int],
              band: tuple[int, int] | None = None) -> U8Image:
        """The whole frame: ``paint`` (h, w, 3) lit from ``pose``, noise from ``noise_at``;
        with ``band`` (first, last) only those rows, the same bytes as the whole frame's
        (each row is lit on its own, from the whole view's gain)."""
        h, w = self.mount.height_px, self.mount.width_px
        top, bottom = (0, h) if band is None else (band[0], band[1] + 1)
        out: U8Image = np.empty((bottom - top, w, 3), np.uint8)
        oy, ox = noise_at
        gain = self._gain(pose)
        # Light and noise a band of rows at a time: the float images of a band stay in the
        # cache, where whole-frame ones (1 MB each) went to memory and back at every step.
        for r0 in range(top, bottom, _BAND_ROWS):
            r1 = min(bottom, r0 + _BAND_ROWS)
            n = r1 - r0
            g3, lit = self._gain3[:n], self._lit[:n]
            cv2.merge([gain[r0:r1]] * 3, dst=g3)
            cv2.multiply(paint[r0:r1], g3, dst=lit, dtype=cv2.CV_32F)
            cv2.add(lit, self.noise[oy + r0:oy + r1, ox:ox + w], dst=out[r0 - top:r1 - top],
                    dtype=cv2.CV_8U)  # saturates to 0-255
        return out

    def dark(self, noise_at: tuple[int, int], rows: Sequence[int] | None = None) -> U8Image:
        """A covered lens: nothing but noise on a dark level (``rows``: those rows only)."""
        h, w = self.mount.height_px, self.mount.width_px
        oy, ox = noise_at
        if rows is None:
            noise = self.noise[oy:oy + h, ox:ox + w]
        else:
            noise = self.noise[oy + np.asarray(rows, np.intp), ox:ox + w]
        if noise.shape[0] == 0:
            return np.empty((0, w, 3), np.uint8)
        dark = np.full(noise.shape, _DARK, np.float32)
        out: U8Image = cv2.add(dark, noise, dtype=cv2.CV_8U)  # saturates to 0-255
        return out

    # --- the fields, kept while the pose is ---------------------------------------------------
    def texture_affine(self, pose: Pose) -> Affine:
        """Destination pixel -> texture pixel: the texture is laid on the floor at camera scale
        (``cv2.warpAffine``'s inverse map)."""
        if self._affine is not None and self._affine[0] == pose:
            return self._affine[1]
        m = self.mount
        mpp = m.m_per_px
        c, s = math.cos(pose.heading_rad), math.sin(pose.heading_rad)
        x0, y0 = m.px_to_floor(pose, 0.0, 0.0)
        xc, yc = pose.to_world(m.forward_m, 0.0)
        n = TEXTURE_TILE_PX
        # Whole tiles taken off so the view centre lands in the middle tile of the texture.
        base = self._texture_centre - n / 2
        shift_x = n * math.floor(xc / mpp / n) - base
        shift_y = n * math.floor(yc / mpp / n) - base
        affine = (s, -c, x0 / mpp - shift_x, -c, -s, y0 / mpp - shift_y)
        self._affine = (pose, affine)
        return affine

    def texture_gain(self, pose: Pose) -> F32Array:
        """The floor texture under the whole view."""
        if self._texture_pose != pose:
            a = self.texture_affine(pose)
            m = self.mount
            cv2.warpAffine(self.texture, np.array([a[:3], a[3:]], np.float64),
                           (m.width_px, m.height_px), dst=self._texture_buf,
                           flags=cv2.INTER_NEAREST | cv2.WARP_INVERSE_MAP,
                           borderMode=cv2.BORDER_REFLECT)
            self._texture_pose = pose
        return self._texture_buf

    def ambient_gain(self, pose: Pose) -> F32Array:
        """The room light over the whole view: a coarse grid of the world-fixed field,
        resized (``cv2.resize``, INTER_LINEAR)."""
        if self._ambient_pose != pose:
            m = self.mount
            cv2.resize(self._ambient_coarse(pose), (m.width_px, m.height_px),
                       dst=self._ambient_buf, interpolation=cv2.INTER_LINEAR)
            self._ambient_pose = pose
        return self._ambient_buf

    def _ambient_coarse(self, pose: Pose) -> F32Array:
        """The room light's field on the coarse grid seen from ``pose``."""
        fwd, left = self._ambient_grid
        c, s = math.cos(pose.heading_rad), math.sin(pose.heading_rad)
        x = pose.x_m + c * fwd - s * left
        y = pose.y_m + s * fwd + c * left
        p = self._phases
        field = (np.sin(x * 2.1 + p[0]) * np.sin(y * 1.7 + p[1])
                 + 0.5 * np.sin(x * 5.3 + y * 3.1 + p[2]))
        coarse: F32Array = (1.0 + self.mount.ambient_variation * field / 1.5).astype(np.float32)
        return coarse

    def _gain(self, pose: Pose) -> F32Array:
        """Light reaching each pixel: floor texture x lens and LED falloff x room light."""
        if self._gain_pose != pose:
            cv2.multiply(self.texture_gain(pose), self.static_gain, dst=self._gain_buf)
            cv2.multiply(self._gain_buf, self.ambient_gain(pose), dst=self._gain_buf)
            self._gain_pose = pose
        return self._gain_buf

    def _make_static_gain(self) -> F32Array:
        m = self.mount
        mpp = m.m_per_px
        cols = (np.arange(m.width_px, dtype=np.float32) - m.width_px / 2) * mpp
        rows = (np.arange(m.height_px, dtype=np.float32) - m.height_px / 2) * mpp
        r2 = cols[None, :] ** 2 + rows[:, None] ** 2
        cos4 = (m.height_m**2 / (m.height_m**2 + r2)) ** 2
        cos4 /= cos4.max()
        corner = float(cos4.min())
        falloff = (1.0 - cos4) / max(1.0 - corner, 1e-6)
        gradient = 1.0 + m.light_gradient * (np.linspace(-0.5, 0.5, m.width_px, dtype=np.float32))
        gain = (1.0 - m.vignette * falloff) * gradient[None, :]
        return gain.astype(np.float32)
