"""A simulated downward-looking camera: renders the floor under the robot as BGR frames.

The image is what the real tracker reads: painted lines in their colours, a floor texture fixed
to the world, light that falls off towards the corners and varies over the floor, sensor noise
and motion blur from the wheel speeds. Frames are captured at the mount's rate on the event
loop's clock; a frame is only rendered when somebody looks at it, so an idle camera costs little
(sim/devices/frame_source.py), and only the rows asked for when those are all that is read
(the line tracker's scan rows: ``Frame.rows``): the same bytes as those rows of the whole frame.
The light and noise are sim/devices/lighting/.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple

import cv2
import numpy as np
import numpy.typing as npt

from sim.devices.frame_source import FrameSource
from sim.devices.lighting.floor_light import FloorLight, make_texture
from sim.world.body import DiffDriveBody
from sim.world.floor_plan import PaintedLine, World
from sim.world.geometry import Pose, SegmentSet

U8Image = npt.NDArray[Any]  # uint8 BGR

_DRAW_SHIFT = 4  # cv2 fixed-point bits: sub-pixel line positions
_NOISE_DRAWS = 256  # noise offsets drawn at a time


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
class _LinePaint:
    """A painted line as the camera draws it: its segments, how near to the view's centre
    they must come to be seen, its thickness (pixels), colour and anti-aliasing margin."""

    line: PaintedLine
    segments: SegmentSet
    ends: npt.NDArray[np.float64]  # (n, 4) x1, y1, x2, y2, C-contiguous
    limit_m: float
    thickness: int
    bgr: tuple[int, ...]
    margin: float


_Placed = tuple[list[tuple[tuple[int, int], tuple[int, int]]], float, float, float, float] | None


class _Shot(NamedTuple):
    """What the camera captured at one instant; rendered into an image on demand (a named
    tuple: one is made 30 times a second, and a frozen dataclass is slower to make)."""

    seq: int
    t_s: float
    pose: Pose
    wheel_mps: tuple[float, float]
    noise_at: tuple[int, int]
    covered: bool = False  # a hand over the lens at the instant


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
        texture = make_texture(self._rng, self.mount.texture_std, self.width_px, self.height_px)
        # Sensor noise: a bank twice the frame size, read at a random offset for each frame;
        # int8 keeps it at 3.7 MB at 640 x 480.
        noise = np.clip(np.rint(self._rng.normal(
            0.0, self.mount.noise_std, (2 * self.height_px, 2 * self.width_px, 3))),
            -127, 127).astype(np.int8)
        self._segments: dict[int, _LinePaint] = {}
        self._light = FloorLight(self.mount, texture, noise, self._rng.uniform(0, 2 * math.pi, 4))
        self._offsets: list[tuple[int, int]] = []  # noise offsets drawn ahead, last one next
        self._paint_buf = np.empty((self.height_px, self.width_px, 3), np.uint8)
        self._paint_key: tuple[Any, ...] | None = None
        # What the last paint left: the lines' box, the rows a band's blur took (top row,
        # left column, their sharp pixels) and the box touched on which bare floor image.
        self._drawn: tuple[int, int, int, int] | None = None
        self._sharp: tuple[int, int, U8Image] | None = None
        self._dirty: tuple[U8Image, tuple[int, int, int, int] | None] | None = None
        self._floor: tuple[tuple[int, int, int], U8Image] | None = None
        self.covered = False

    # --- physics-style methods ----------------------------------------------------------------
    def cover(self, covered: bool = True) -> None:
        """Put a hand over the lens: frames go dark (the tracker must call that lost)."""
        self.covered = covered

    def render(self, pose: Pose, wheel_mps: tuple[float, float] = (0.0, 0.0)) -> U8Image:
        """Render what the camera sees from ``pose`` (fresh noise), without the clock."""
        self.frames_rendered += 1
        return self._render_shot(_Shot(0, 0.0, pose, wheel_mps, self._noise_offset(),
                                       self.covered))

    # --- FrameSource ---------------------------------------------------------------------------
    def _snapshot(self, seq: int, t_s: float) -> _Shot:
        wheels = (float(self.body.wheel_mps[0]), float(self.body.wheel_mps[1]))
        return _Shot(seq, t_s, self.body.pose, wheels, self._noise_offset(), self.covered)

    def _draw(self, shot: _Shot) -> U8Image:
        return self._render_shot(shot)

    def _draw_rows(self, shot: _Shot, rows: Sequence[int]) -> U8Image:
        return self._render_rows(shot, rows)

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
        """The next (row, column) of the noise bank to read a frame's noise at.

        Drawn ahead, _NOISE_DRAWS pairs in one call: the generator gives the numbers that one
        call a row and one a column gave (tests/sim/devices/test_camera_lines.py), and
        nothing else draws from it once the camera is made.
        """
        if not self._offsets:
            drawn = self._rng.integers(0, (self.height_px, self.width_px), (_NOISE_DRAWS, 2))
            self._offsets = [(int(r), int(c)) for r, c in drawn.tolist()][::-1]
        return self._offsets.pop()

    def _render_shot(self, shot: _Shot) -> U8Image:
        if shot.covered:
            return self._light.dark(shot.noise_at)
        return self._light.light(self._paint(shot.pose, shot.wheel_mps), shot.pose, shot.noise_at)

    def _render_rows(self, shot: _Shot, rows: Sequence[int]) -> U8Image:
        """Rows ``rows`` of ``_render_shot(shot)``, the same bytes; only those rows are lit,
        and the motion blur is done on the band they span (the lines are drawn whole: drawn
        into a band, anti-aliased lines are not provably the same pixels)."""
        if shot.covered:
            return self._light.dark(shot.noise_at, rows)
        if len(rows) == 0:
            return np.empty((0, self.width_px, 3), np.uint8)
        first, last = min(rows), max(rows)
        if first < 0 or last >= self.height_px:
            msg = f"{self.name}: rows {first}..{last} outside 0..{self.height_px - 1}"
            raise IndexError(msg)
        paint = self._paint(shot.pose, shot.wheel_mps, (first, last))
        lit: U8Image = self._light.light(paint, shot.pose, shot.noise_at, (first, last))
        return lit[np.asarray(rows, np.intp) - first]

    def _paint(self, pose: Pose, wheel_mps: tuple[float, float],
               band: tuple[int, int] | None = None) -> U8Image:
        """The floor and its lines as the lens sees them, blurred by the motion (``band``:
        only rows ``band[0]..band[1]`` need be right; only those are blurred).

        Kept while the robot stands still (and the floor and its lines are the same); drawn
        into the same buffer every frame (a fresh image a frame costs page faults worth as much
        as the drawing).
        """
        whole = (pose, wheel_mps, self.world.floor_bgr, tuple(self.world.lines))
        paint = self._paint_buf
        key = self._paint_key
        if key in (whole, (*whole, band)):  # a whole paint serves any band
            return paint
        if band is None and key is not None and key[:4] == whole and self._sharp is not None:
            # This shot's rows were painted (a recorder now wants the whole frame): the lines
            # are drawn; the rows blurred for them are put back sharp and the whole box blurred.
            y0, x0, sharp = self._sharp
            paint[y0:y0 + sharp.shape[0], x0:x0 + sharp.shape[1]] = sharp
            self._sharp = None
            self._blur(paint, wheel_mps, self._drawn)
            self._paint_key = whole
            return paint
        self._restore_floor(paint)
        self._sharp = None
        drawn = self._drawn = self._draw_lines(paint, pose)
        # Blurring the paint before lighting it is close enough: the light field is smooth.
        self._blur(paint, wheel_mps, drawn, band)
        # Nothing blurred for the band alone (no blur, no lines): the paint is whole.
        self._paint_key = whole if band is None or self._sharp is None else (*whole, band)
        return paint

    def _restore_floor(self, paint: U8Image) -> None:
        """The bare floor back in the paint buffer: only the box the last paint touched (lines
        and blur stay inside it: ``_blur`` relies on that too), when on the same floor."""
        floor = self._bare_floor()
        dirty, self._dirty = self._dirty, None
        if dirty is None or dirty[0] is not floor:
            np.copyto(paint, floor)
        elif dirty[1] is not None:
            x0, y0, x1, y1 = dirty[1]
            paint[y0:y1, x0:x1] = floor[y0:y1, x0:x1]

    def _draw_lines(self, image: U8Image, pose: Pose) -> tuple[int, int, int, int] | None:
        """Paint the lines near the view; returns the box (x0, y0, x1, y1) they touch, if any.

        The segments in view are found and placed by ``_place_segments``; the anti-aliased
        lines are OpenCV's.
        """
        m = self.mount
        c, s = math.cos(pose.heading_rad), math.sin(pose.heading_rad)
        box: list[float] = []
        for line in self.world.lines:
            paint = self._line_paint(line)
            if paint.ends.shape[0] == 0:
                continue
            placed = self._place_segments(paint, pose, c, s)
            if placed is None:
                continue
            points, lo_col, lo_row, hi_col, hi_row = placed
            for a, b in points:
                cv2.line(image, a, b, paint.bgr, paint.thickness, cv2.LINE_AA, _DRAW_SHIFT)
            margin = paint.margin
            box = _grow(box, lo_col - margin, lo_row - margin, hi_col + margin, hi_row + margin)
        if not box:
            return None
        x0, y0 = max(0, math.floor(box[0])), max(0, math.floor(box[1]))
        x1, y1 = min(m.width_px, math.ceil(box[2]) + 1), min(m.height_px, math.ceil(box[3]) + 1)
        return (x0, y0, x1, y1) if x0 < x1 and y0 < y1 else None

    def _place_segments(self, paint: _LinePaint, pose: Pose, c: float, s: float) -> _Placed:
        """The segments of a line near the view in fixed-point pixels, and the box of their
        unrounded ends (None: none near)."""
        m = self.mount
        mpp = m.m_per_px
        cx, cy = pose.to_world(m.forward_m, 0.0)
        near = np.flatnonzero(paint.segments.distances(cx, cy) < paint.limit_m)
        if near.shape[0] == 0:
            return None
        scale = 1 << _DRAW_SHIFT
        half_w, half_h = m.width_px / 2, m.height_px / 2
        cols: list[float] = []
        rows: list[float] = []
        points = []
        for x1, y1, x2, y2 in paint.ends[near].tolist():
            ends = []
            for x, y in ((x1, y1), (x2, y2)):
                dx, dy = x - pose.x_m, y - pose.y_m
                fwd, left = c * dx + s * dy, -s * dx + c * dy
                col = half_w - left / mpp - 0.5
                row = half_h - (fwd - m.forward_m) / mpp - 0.5
                cols.append(col)
                rows.append(row)
                ends.append((round(col * scale), round(row * scale)))
            points.append((ends[0], ends[1]))
        return points, min(cols), min(rows), max(cols), max(rows)

    def _line_paint(self, line: PaintedLine) -> _LinePaint:
        cached = self._segments.get(id(line))
        if cached is None or cached.line is not line:
            m = self.mount
            segments = SegmentSet(line.segments())
            reach_m = math.hypot(m.view_width_m, m.m_per_px * m.height_px) / 2
            thickness = max(1, round(line.width_m / m.m_per_px))
            cached = _LinePaint(line, segments, np.ascontiguousarray(segments.ends, np.float64),
                                reach_m + line.width_m, thickness,
                                tuple(int(v) for v in line.bgr),
                                thickness / 2 + 3)  # anti-aliasing reaches past the width
            self._segments[id(line)] = cached
        return cached

    def _blur(self, image: U8Image, wheel_mps: tuple[float, float],
              drawn: tuple[int, int, int, int] | None,
              band: tuple[int, int] | None = None) -> U8Image:
        """Motion blur; only around the paint (``drawn``): blurring bare floor changes nothing.

        ``band``: only rows ``band[0]..band[1]`` are wanted; the blur then covers them and
        half a kernel beyond (or up to the painted box's edge, whose mirrored border it reads
        as the whole blur does): the box filter's integer sums make those rows the same.
        """
        m = self.mount
        speed = (wheel_mps[0] + wheel_mps[1]) / 2
        yaw_rps = (wheel_mps[1] - wheel_mps[0]) / self.body.params.wheel_base_m
        along_px = abs(speed) * m.exposure_s / m.m_per_px
        across_px = abs(yaw_rps) * m.forward_m * m.exposure_s / m.m_per_px
        # Odd box sizes: an even one has no centre pixel and shifts the image half a pixel.
        ky, kx = 1 + 2 * round(along_px / 2), 1 + 2 * round(across_px / 2)
        self._dirty = (self._bare_floor(), drawn)
        if (kx == 1 and ky == 1) or drawn is None:
            return image
        # The box is grown by a kernel width of bare floor, so the mirrored border cv2 reads at
        # its edges is floor, as the real neighbours are.
        x0, y0, x1, y1 = drawn
        x0, x1 = max(0, x0 - kx), min(m.width_px, x1 + kx)
        y0, y1 = max(0, y0 - ky), min(m.height_px, y1 + ky)
        self._dirty = (self._bare_floor(), (x0, y0, x1, y1))
        if band is not None:
            y0, y1 = max(y0, band[0] - ky // 2), min(y1, band[1] + ky // 2 + 1)
            y1 = max(y0, y1)
            # Kept sharp: a whole frame of the same shot blurs them again (``_paint``).
            self._sharp = (y0, x0, image[y0:y1, x0:x1].copy())
            if y0 == y1:
                return image
        region = image[y0:y1, x0:x1]
        region[:] = cv2.blur(region, (kx, ky))
        return image


def _grow(box: list[float], x0: float, y0: float, x1: float, y1: float) -> list[float]:
    if not box:
        return [x0, y0, x1, y1]
    return [min(box[0], x0), min(box[1], y0), max(box[2], x1), max(box[3], y1)]
