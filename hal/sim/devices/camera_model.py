"""A simulated downward-looking camera: renders the floor under the robot as BGR frames.

The image is what the real tracker reads: painted lines in their colours, a floor texture fixed
to the world, light that falls off towards the corners and varies over the floor, sensor noise
and motion blur from the wheel speeds. Frames are captured at the mount's rate on the event
loop's clock; a frame is only rendered when somebody looks at it, so an idle camera costs little
(hal/sim/devices/frame_source.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np
import numpy.typing as npt

from hal.sim.devices.frame_source import FrameSource
from hal.sim.world.body import DiffDriveBody
from hal.sim.world.floor_plan import PaintedLine, World
from hal.sim.world.geometry import Pose, SegmentSet

F32Array = npt.NDArray[Any]  # float32; cv2 returns loosely typed arrays
U8Image = npt.NDArray[Any]  # uint8 BGR

try:
    from hal.sim.devices import _camera_light
except ImportError:  # not built (no C compiler or Python headers): OpenCV calls, same pixels
    _camera_light = None  # type: ignore[assignment]

_TEXTURE_TILE_PX = 256
_DRAW_SHIFT = 4  # cv2 fixed-point bits: sub-pixel line positions
_AMBIENT_GRID = (8, 6)  # coarse grid the world-fixed light field is computed on
_BAND_ROWS = 32  # rows lit at a time: a band's float images fit in the CPU's cache


@dataclass(frozen=True, slots=True)
class CameraMount:
    """Where the camera sits on the robot and what it sees of the floor."""

    height_m: float = 0.10  # lens above the floor; sets how fast the LED light falls off
    forward_m: float = 0.15  # centre of the view ahead of the wheel axle
    view_width_m: float = 0.24  # floor seen across the image width (height follows the aspect)
    width_px: int = 320
    height_px: int = 240
    fps: float = 30.0
    exposure_s: float = 0.012  # motion blur length = speed x exposure
    noise_std: float = 4.0  # sensor noise, grey levels
    texture_std: float = 0.04  # floor texture, relative brightness
    vignette: float = 0.25  # brightness lost in the corners (cos^4 law of the on-board LED)
    light_gradient: float = 0.15  # brightness slope across the image, left to right
    ambient_variation: float = 0.15  # world-fixed patches of light and shade

    def __post_init__(self) -> None:
        if self.width_px < 16 or self.height_px < 16:
            msg = f"camera resolution {self.width_px}x{self.height_px}: at least 16x16"
            raise ValueError(msg)
        if self.fps <= 0 or self.view_width_m <= 0 or self.height_m <= 0:
            msg = "camera fps, view_width_m and height_m must be > 0"
            raise ValueError(msg)

    @property
    def m_per_px(self) -> float:
        return self.view_width_m / self.width_px

    def floor_to_px(self, pose: Pose, x_m: float, y_m: float) -> tuple[float, float]:
        """Image (column, row) of a floor point; column 0 is the robot's left, row 0 farthest."""
        c, s = math.cos(pose.heading_rad), math.sin(pose.heading_rad)
        dx, dy = x_m - pose.x_m, y_m - pose.y_m
        fwd, left = c * dx + s * dy, -s * dx + c * dy
        mpp = self.m_per_px
        col = self.width_px / 2 - left / mpp - 0.5
        row = self.height_px / 2 - (fwd - self.forward_m) / mpp - 0.5
        return col, row

    def px_to_floor(self, pose: Pose, col: float, row: float) -> tuple[float, float]:
        """Floor point (world metres) seen at image (column, row)."""
        mpp = self.m_per_px
        fwd = self.forward_m + (self.height_px / 2 - row - 0.5) * mpp
        left = (self.width_px / 2 - col - 0.5) * mpp
        return pose.to_world(fwd, left)


@dataclass(frozen=True, slots=True)
class _Shot:
    """What the camera captured at one instant; rendered into an image on demand."""

    seq: int
    t_s: float
    pose: Pose
    wheel_mps: tuple[float, float]
    noise_at: tuple[int, int]


class _Buffers:
    """The images a render works in, kept from frame to frame (see ``SimCamera._render_shot``)."""

    def __init__(self, height_px: int, width_px: int) -> None:
        self.paint = np.empty((height_px, width_px, 3), np.uint8)
        self.texture = np.empty((height_px, width_px), np.float32)
        self.ambient = np.empty((height_px, width_px), np.float32)
        self.gain = np.empty((height_px, width_px), np.float32)
        self.gain3 = np.empty((_BAND_ROWS, width_px, 3), np.float32)
        self.lit = np.empty((_BAND_ROWS, width_px, 3), np.float32)


class SimCamera(FrameSource[_Shot]):
    """A `hal.devices.Camera` over the simulated world, looking down from the robot's body.

    Args:
        world: the floor plan with its painted lines.
        body: the robot body whose pose and wheel speeds the camera follows.
        mount: position, field of view, resolution, rate and image defects.
        seed: seeds texture, light field and noise, so runs repeat.
    """

    def __init__(self, world: World, body: DiffDriveBody, mount: CameraMount | None = None,
                 *, seed: int = 1, name: str = "camera") -> None:
        self.mount = mount or CameraMount()
        super().__init__(self.mount.fps)
        self.name = name
        self.world = world
        self.body = body
        self.width_px = self.mount.width_px
        self.height_px = self.mount.height_px
        self._rng = np.random.default_rng(seed)
        self._texture = self._make_texture()
        # Sensor noise: a bank twice the frame size, read at a random offset for each frame;
        # int8 keeps it at 3.7 MB at 640 x 480.
        self._noise = np.clip(np.rint(self._rng.normal(
            0.0, self.mount.noise_std, (2 * self.height_px, 2 * self.width_px, 3))),
            -127, 127).astype(np.int8)
        self._static_gain = self._make_static_gain()
        gw, gh = _AMBIENT_GRID
        cc, rr = np.meshgrid(np.linspace(0, self.width_px - 1, gw),
                             np.linspace(0, self.height_px - 1, gh))
        mpp = self.mount.m_per_px
        self._ambient_grid = (self.mount.forward_m + (self.height_px / 2 - rr - 0.5) * mpp,
                              (self.width_px / 2 - cc - 0.5) * mpp)
        self._segments: dict[int, tuple[PaintedLine, SegmentSet]] = {}
        self._phases = self._rng.uniform(0, 2 * math.pi, 4)
        self._bufs = _Buffers(self.height_px, self.width_px)
        self._paint_key: tuple[Any, ...] | None = None
        self._gain_pose: Pose | None = None
        self._fields_pose: Pose | None = None
        # The C pass rounds as OpenCV does for gains > 0 and lit values below 2**22.
        bounded = (float(self._texture.min()) > 0 and float(self._static_gain.min()) > 0
                   and self.mount.ambient_variation < 1
                   and 255 * float(self._texture.max()) * float(self._static_gain.max())
                   * (1 + self.mount.ambient_variation) < 2**22)
        self.light_kernel = "c" if _camera_light is not None and bounded else "opencv"
        self._floor: tuple[tuple[int, int, int], U8Image] | None = None
        self.covered = False

    # --- physics-style methods ----------------------------------------------------------------
    def cover(self, covered: bool = True) -> None:
        """Put a hand over the lens: frames go dark (the tracker must call that lost)."""
        self.covered = covered

    def render(self, pose: Pose, wheel_mps: tuple[float, float] = (0.0, 0.0)) -> U8Image:
        """Render what the camera sees from ``pose`` (fresh noise), without the clock."""
        self.frames_rendered += 1
        return self._render_shot(_Shot(0, 0.0, pose, wheel_mps, self._noise_offset()))

    # --- FrameSource ---------------------------------------------------------------------------
    def _snapshot(self, seq: int, t_s: float) -> _Shot:
        wheels = (float(self.body.wheel_mps[0]), float(self.body.wheel_mps[1]))
        return _Shot(seq, t_s, self.body.pose, wheels, self._noise_offset())

    def _draw(self, shot: _Shot) -> U8Image:
        return self._render_shot(shot)

    def _status_extra(self) -> dict[str, Any]:
        return {"covered": self.covered}

    # --- internals ----------------------------------------------------------------------------
    def _bare_floor(self) -> U8Image:
        floor = self.world.floor_bgr
        if self._floor is None or self._floor[0] != floor:
            image = np.empty((self.height_px, self.width_px, 3), np.uint8)
            image[:] = floor
            self._floor = (floor, image)
        return self._floor[1]

    def _noise_offset(self) -> tuple[int, int]:
        return int(self._rng.integers(0, self.height_px)), int(self._rng.integers(0, self.width_px))

    def _render_shot(self, shot: _Shot) -> U8Image:
        m = self.mount
        h, w = m.height_px, m.width_px
        if self.covered:
            dark = np.full((h, w, 3), 8.0, np.float32)
            return self._finish(dark, shot.noise_at)
        paint = self._paint(shot.pose, shot.wheel_mps)
        b = self._bufs
        out: U8Image = np.empty((h, w, 3), np.uint8)
        oy, ox = shot.noise_at
        if self.light_kernel == "c" and _camera_light is not None:
            # The steps below in one pass, to the bit (hal/sim/devices/_camera_light.c).
            self._light_fields(shot.pose)
            _camera_light.light(paint, b.texture, self._static_gain, b.ambient, self._noise,
                                oy, ox, out)
            return out
        gain = self._gain(shot.pose)
        # Light and noise a band of rows at a time: the float images of a band stay in the
        # cache, where whole-frame ones (1 MB each) went to memory and back at every step.
        for r0 in range(0, h, _BAND_ROWS):
            r1 = min(h, r0 + _BAND_ROWS)
            n = r1 - r0
            g3, lit = b.gain3[:n], b.lit[:n]
            cv2.merge([gain[r0:r1]] * 3, dst=g3)
            cv2.multiply(paint[r0:r1], g3, dst=lit, dtype=cv2.CV_32F)
            cv2.add(lit, self._noise[oy + r0:oy + r1, ox:ox + w], dst=out[r0:r1],
                    dtype=cv2.CV_8U)  # saturates to 0-255
        return out

    def _paint(self, pose: Pose, wheel_mps: tuple[float, float]) -> U8Image:
        """The floor and its lines as the lens sees them, blurred by the motion.

        Kept while the robot stands still (and the floor and its lines are the same); drawn
        into the same buffer every frame (a fresh image a frame costs page faults worth as much
        as the drawing).
        """
        key = (pose, wheel_mps, self.world.floor_bgr, tuple(self.world.lines))
        b = self._bufs
        if self._paint_key != key:
            np.copyto(b.paint, self._bare_floor())
            drawn = self._draw_lines(b.paint, pose)
            # Blurring the paint before lighting it is close enough: the light field is smooth.
            self._blur(b.paint, wheel_mps, drawn)
            self._paint_key = key
        return b.paint

    def _finish(self, lit: F32Array, noise_at: tuple[int, int]) -> U8Image:
        oy, ox = noise_at
        noise = self._noise[oy:oy + self.height_px, ox:ox + self.width_px]
        out: U8Image = cv2.add(lit, noise, dtype=cv2.CV_8U)  # saturates to 0-255
        return out

    def _draw_lines(self, image: U8Image, pose: Pose) -> tuple[int, int, int, int] | None:
        """Paint the lines near the view; returns the box (x0, y0, x1, y1) they touch, if any.

        The few segments in view are placed with scalar arithmetic: numpy's per-call cost was
        most of this method's time on a frame's handful of points (same floats either way).
        """
        m = self.mount
        mpp = m.m_per_px
        cx, cy = pose.to_world(m.forward_m, 0.0)
        reach_m = math.hypot(m.view_width_m, mpp * m.height_px) / 2
        scale = 1 << _DRAW_SHIFT
        c, s = math.cos(pose.heading_rad), math.sin(pose.heading_rad)
        half_w, half_h = m.width_px / 2, m.height_px / 2
        box: list[float] = []
        for line in self.world.lines:
            segs = self._line_segments(line)
            if segs.x1.shape[0] == 0:
                continue
            near = np.flatnonzero(segs.distances(cx, cy) < reach_m + line.width_m)
            if near.shape[0] == 0:
                continue
            thickness = max(1, round(line.width_m / mpp))
            colour = tuple(int(v) for v in line.bgr)
            cols: list[float] = []
            rows: list[float] = []
            for x1, y1, x2, y2 in segs.ends[near].tolist():
                ends = []
                for x, y in ((x1, y1), (x2, y2)):
                    dx, dy = x - pose.x_m, y - pose.y_m
                    fwd, left = c * dx + s * dy, -s * dx + c * dy
                    col = half_w - left / mpp - 0.5
                    row = half_h - (fwd - m.forward_m) / mpp - 0.5
                    cols.append(col)
                    rows.append(row)
                    ends.append((round(col * scale), round(row * scale)))
                cv2.line(image, ends[0], ends[1], colour, thickness, cv2.LINE_AA, _DRAW_SHIFT)
            margin = thickness / 2 + 3  # anti-aliasing reaches past the nominal width
            box = _grow(box, min(cols) - margin, min(rows) - margin,
                        max(cols) + margin, max(rows) + margin)
        if not box:
            return None
        x0, y0 = max(0, math.floor(box[0])), max(0, math.floor(box[1]))
        x1, y1 = min(m.width_px, math.ceil(box[2]) + 1), min(m.height_px, math.ceil(box[3]) + 1)
        return (x0, y0, x1, y1) if x0 < x1 and y0 < y1 else None

    def _line_segments(self, line: PaintedLine) -> SegmentSet:
        cached = self._segments.get(id(line))
        if cached is None or cached[0] is not line:
            cached = (line, SegmentSet(line.segments()))
            self._segments[id(line)] = cached
        return cached[1]

    def _make_texture(self) -> F32Array:
        """A seamless tile of floor texture, repeated so the whole view fits inside it.

        Reading inside one big periodic image is ten times faster than cv2's wrap-around
        border, and shifting by whole tiles is invisible, so the texture stays world-fixed.
        """
        n = _TEXTURE_TILE_PX
        fine = self._rng.normal(0.0, 1.0, (n, n)).astype(np.float32)
        noise = np.tile(self._rng.normal(0.0, 1.0, (n, n)).astype(np.float32), (3, 3))
        blurred: F32Array = cv2.GaussianBlur(noise, (0, 0), 6)[n:2 * n, n:2 * n]
        blotches = blurred / max(float(blurred.std()), 1e-6)
        tile = 1.0 + self.mount.texture_std * (0.6 * fine + 0.8 * blotches)
        reps = math.ceil(math.hypot(self.width_px, self.height_px) / n) + 2
        self._texture_centre = reps * n / 2
        return np.tile(tile.astype(np.float32), (reps, reps))

    def _texture_gain(self, pose: Pose, dst: F32Array | None = None) -> F32Array:
        m = self.mount
        mpp = m.m_per_px
        c, s = math.cos(pose.heading_rad), math.sin(pose.heading_rad)
        x0, y0 = m.px_to_floor(pose, 0.0, 0.0)
        xc, yc = pose.to_world(m.forward_m, 0.0)
        n = _TEXTURE_TILE_PX
        # Whole tiles taken off so the view centre lands in the middle tile of the texture.
        base = self._texture_centre - n / 2
        shift_x = n * math.floor(xc / mpp / n) - base
        shift_y = n * math.floor(yc / mpp / n) - base
        # Destination pixel -> texture pixel: the texture is laid on the floor at camera scale.
        affine = np.array([[s, -c, x0 / mpp - shift_x], [-c, -s, y0 / mpp - shift_y]],
                          np.float64)
        out: F32Array = cv2.warpAffine(self._texture, affine, (m.width_px, m.height_px),
                                       dst=dst, flags=cv2.INTER_NEAREST | cv2.WARP_INVERSE_MAP,
                                       borderMode=cv2.BORDER_REFLECT)
        return out

    def _light_fields(self, pose: Pose) -> None:
        """The floor texture and the room light under the view, kept while the pose is."""
        if self._fields_pose != pose:
            self._texture_gain(pose, self._bufs.texture)
            self._ambient_gain(pose, self._bufs.ambient)
            self._fields_pose = pose

    def _gain(self, pose: Pose) -> F32Array:
        """Light reaching each pixel: floor texture x lens and LED falloff x room light."""
        b = self._bufs
        if self._gain_pose != pose:
            self._light_fields(pose)
            cv2.multiply(b.texture, self._static_gain, dst=b.gain)
            cv2.multiply(b.gain, b.ambient, dst=b.gain)
            self._gain_pose = pose
        return b.gain

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

    def _ambient_gain(self, pose: Pose, dst: F32Array | None = None) -> F32Array:
        m = self.mount
        fwd, left = self._ambient_grid
        c, s = math.cos(pose.heading_rad), math.sin(pose.heading_rad)
        x = pose.x_m + c * fwd - s * left
        y = pose.y_m + s * fwd + c * left
        p = self._phases
        field = (np.sin(x * 2.1 + p[0]) * np.sin(y * 1.7 + p[1])
                 + 0.5 * np.sin(x * 5.3 + y * 3.1 + p[2]))
        coarse = (1.0 + m.ambient_variation * field / 1.5).astype(np.float32)
        out: F32Array = cv2.resize(coarse, (m.width_px, m.height_px), dst=dst,
                                   interpolation=cv2.INTER_LINEAR)
        return out

    def _blur(self, image: U8Image, wheel_mps: tuple[float, float],
              drawn: tuple[int, int, int, int] | None) -> U8Image:
        """Motion blur; only around the paint (``drawn``): blurring bare floor changes nothing."""
        m = self.mount
        speed = (wheel_mps[0] + wheel_mps[1]) / 2
        yaw_rps = (wheel_mps[1] - wheel_mps[0]) / self.body.params.wheel_base_m
        along_px = abs(speed) * m.exposure_s / m.m_per_px
        across_px = abs(yaw_rps) * m.forward_m * m.exposure_s / m.m_per_px
        # Odd box sizes: an even one has no centre pixel and shifts the image half a pixel.
        ky, kx = 1 + 2 * round(along_px / 2), 1 + 2 * round(across_px / 2)
        if (kx == 1 and ky == 1) or drawn is None:
            return image
        # The box is grown by a kernel width of bare floor, so the mirrored border cv2 reads at
        # its edges is floor, as the real neighbours are.
        x0, y0, x1, y1 = drawn
        x0, x1 = max(0, x0 - kx), min(m.width_px, x1 + kx)
        y0, y1 = max(0, y0 - ky), min(m.height_px, y1 + ky)
        region = image[y0:y1, x0:x1]
        region[:] = cv2.blur(region, (kx, ky))
        return image


def _grow(box: list[float], x0: float, y0: float, x1: float, y1: float) -> list[float]:
    if not box:
        return [x0, y0, x1, y1]
    return [min(box[0], x0), min(box[1], y0), max(box[2], x1), max(box[3], y1)]
