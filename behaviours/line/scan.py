"""The line tracker's scan of its rows: the runs of the wanted colour in each scan row.

Each row gets a per-pixel score for the wanted colour, divided by the local floor brightness
(the row with the line closed over), so light that falls off to the corners or varies over
the floor does not move the line. Runs where the score's 3-tap sums are above the level are
line candidates (gaps of up to _GAP_PX inside a row are noise and joined); a run's middle is
halfway between its edges, each where the sums cross the level, interpolated between two
cells.

Two implementations of the one computation, which tests/behaviours/test_line_scan.py holds
to the same runs:

- ``"c"``: behaviours/line/_line_scan.c, one call per frame. Built when the package is installed
  where a C compiler and Python's headers are (scripts/bootstrap installs them).
- ``"numpy"``: numpy and OpenCV, ~30 array calls per frame; used when the C kernel was not
  built, and by ``ROBOTD_LINE_KERNEL=numpy``.
"""

from __future__ import annotations

import functools
import os
from collections.abc import Callable, Sequence
from typing import Any, Protocol

import cv2
import numpy as np
import numpy.typing as npt
import structlog

from behaviours.line.colours import LineColour

try:
    from behaviours.line import _line_scan
except ImportError:  # not built: no C compiler or Python headers where it was installed
    _line_scan = None  # type: ignore[assignment]

log = structlog.get_logger(__name__)
Plane = npt.NDArray[Any]  # uint8 or float32 rows (cv2 returns loosely typed arrays)
Run = tuple[int, int, int, float, float]
"""A run: scan row (its index), begin and end column (end exclusive; the 3-tap sums reach one
column past the image either side), middle column, mass (the sum of its 3-tap sums)."""

KERNELS = ("c", "numpy")
KERNEL_ENV = "ROBOTD_LINE_KERNEL"
_GREY_TINT = 24  # channel spread (grey levels) a grey surface shows from noise and light
_BACKGROUND_FRAC = 0.17  # background window, fraction of the width: wider than any line
_GAP_PX = 3  # gaps this narrow inside a run are noise
_PAD = 2  # zero columns either side of each row, so runs never cross rows
_KINDS = {"dark": 0, "light": 1, "chroma": 2}
_NOT_BUILT = ("the C line scan was not built: install a C compiler and Python's headers (gcc, "
              "python3-dev), then reinstall robotd (in a checkout: .venv/bin/pip install -e .)")


class RowScan(Protocol):
    """Scans rows of BGR frames for runs of one colour."""

    kernel: str

    def scan(self, image: npt.NDArray[np.uint8], rows: Sequence[int], colour: LineColour,
             level: float) -> tuple[float, list[Run]]:
        """The floor's mean brightness and the runs where the sums are above ``level``."""
        ...


def built_kernel() -> str:
    """The kernel trackers use: ``ROBOTD_LINE_KERNEL`` if set (a value that cannot be used
    is logged and ignored: a diagnostic knob must not keep the robot from starting), else C
    if it was built."""
    built = "c" if _line_scan is not None else "numpy"
    wanted = os.environ.get(KERNEL_ENV, "").strip().lower()
    if not wanted or wanted in (built, "numpy"):
        return wanted or built
    why = _NOT_BUILT if wanted == "c" else f"expected one of {', '.join(KERNELS)}"
    log.warning("line_tracker.kernel_env_ignored", value=wanted, using=built, why=why)
    return built


def row_scan(kernel: str | None = None) -> RowScan:
    """A scanner using ``kernel`` ("c" or "numpy"; None: ``built_kernel()``)."""
    name = kernel or built_kernel()
    if name == "c":
        return CRowScan()
    if name == "numpy":
        return NumpyRowScan()
    msg = f"line scan kernel {name!r}: expected one of {', '.join(KERNELS)}"
    raise ValueError(msg)


def _blocks(width: int) -> int:
    return max(4, width // 8)


@functools.lru_cache(maxsize=8)
def _window(blocks: int) -> int:
    """The background's window, in blocks (odd)."""
    return max(3, round(blocks * _BACKGROUND_FRAC)) | 1


class CRowScan:
    """The scan in C (behaviours/line/_line_scan.c). Rows: indices 0 <= row < the image's height."""

    kernel = "c"

    def __init__(self) -> None:
        if _line_scan is None:
            raise ValueError(_NOT_BUILT)

    def scan(self, image: npt.NDArray[np.uint8], rows: Sequence[int], colour: LineColour,
             level: float) -> tuple[float, list[Run]]:
        if image.strides[1:] != (3, 1):  # the kernel reads packed pixels
            image = np.ascontiguousarray(image)
        blocks = _blocks(image.shape[1])
        wanted = sum(1 << c for c in colour.channels)
        return _line_scan.scan(image, rows, _KINDS[colour.kind], wanted, 7 & ~wanted, level,
                               _GREY_TINT, blocks, _window(blocks) // 2, _GAP_PX)


class NumpyRowScan:
    """The scan in numpy and OpenCV."""

    kernel = "numpy"

    def __init__(self) -> None:
        self._work = _Workspace(0, 0)

    def scan(self, image: npt.NDArray[np.uint8], rows: Sequence[int], colour: LineColour,
             level: float) -> tuple[float, list[Run]]:
        if len(rows) == 0:
            return 0.0, []
        low, high = min(rows), max(rows)
        if low < 0 or high >= image.shape[0] or not level > 0:
            msg = (f"line scan: rows {low}..{high} in an image of {image.shape[0]} rows, "
                   f"level {level} (must be > 0)")
            raise IndexError(msg) if level > 0 else ValueError(msg)
        strip = image[np.asarray(rows, np.intp)]
        if self._work.shape != strip.shape[:2]:
            self._work = _Workspace(*strip.shape[:2])
        work = self._work
        planes, raw = work.planes, work.raw
        cv2.split(strip, planes)
        value = np.maximum(planes[0], planes[1], out=work.value)
        np.maximum(value, planes[2], out=value)
        floor = _background(value, cv2.MORPH_CLOSE)
        if colour.kind in ("dark", "light"):
            # Grey lines only: saturation beyond what noise gives counts against the pixel:
            # tint = max(spread - _GREY_TINT, 0), in uint8 (max >= min: no wrap-around).
            # (The tint as a full plane, not a scalar: numpy's array-array loops are the
            # vectorised ones; likewise cv2 converts uint8 to float faster than numpy.)
            tint = np.minimum(planes[0], planes[1], out=work.tint)
            np.minimum(tint, planes[2], out=tint)
            np.subtract(value, tint, out=tint)
            np.maximum(tint, work.grey_tint, out=tint)
            np.subtract(tint, work.grey_tint, out=tint)
            if colour.kind == "dark":
                cv2.add(value, tint, dst=raw, dtype=cv2.CV_32F)
                np.subtract(floor, raw, out=raw)
            else:
                cv2.subtract(value, tint, dst=raw, dtype=cv2.CV_32F)
                raw -= _background(value, cv2.MORPH_OPEN)
        else:
            wanted = _reduce(cv2.min, [planes[c] for c in colour.channels])
            others = _reduce(cv2.max, [planes[c] for c in (0, 1, 2) if c not in colour.channels])
            cv2.subtract(wanted, others, dst=raw, dtype=cv2.CV_32F)
        np.divide(raw, floor, out=work.score[:, _PAD:-_PAD])
        return float(cv2.mean(floor)[0]), self._runs(level)

    def _runs(self, level: float) -> list[Run]:
        work = self._work
        span = work.shape[1] + 2 * _PAD
        # Each cell plus its neighbours either side: a 3-tap sum that takes the edge off
        # sensor noise; the first and last cell of each row stay 0.
        cells, flat = work.score.ravel(), work.sums
        inner = flat[1:-1]
        np.add(cells[:-2], cells[1:-1], out=inner)
        inner += cells[2:]
        above = flat > level
        # Where runs begin and end (one past their last cell). From here on the work is on
        # a few runs, where plain Python costs less than numpy's calls.
        edges = (above[1:] != above[:-1]).nonzero()[0].tolist()  # each one before the edge
        if not edges:
            return []
        begin, end = _close_gaps([b + 1 for b in edges[0::2]], [e + 1 for e in edges[1::2]],
                                 span)
        mass = np.add.reduceat(flat, [x for pair in zip(begin, end, strict=True)
                                      for x in pair])[0::2].tolist()
        at = flat.item
        runs = []
        for b, e, run_mass in zip(begin, end, mass, strict=True):
            b0, b1, e0, e1 = at(b - 1), at(b), at(e - 1), at(e)
            middle = ((b - 1 + (level - b0) / (b1 - b0)) + (e - 1 + (level - e0) / (e1 - e0))) / 2
            row = b // span
            origin = row * span + _PAD
            runs.append((row, b - origin, e - origin, middle - origin, run_mass))
        return runs


class _Workspace:
    """Arrays a frame's work writes into, kept from frame to frame (allocating a dozen small
    arrays a frame cost more than filling them)."""

    def __init__(self, rows: int, width: int) -> None:
        self.shape = (rows, width)
        self.planes = [np.empty((rows, width), np.uint8) for _ in range(3)]
        self.value = np.empty((rows, width), np.uint8)
        self.tint = np.empty((rows, width), np.uint8)
        self.grey_tint = np.full((rows, width), _GREY_TINT, np.uint8)
        self.raw = np.empty((rows, width), np.float32)
        # The score's rows laid end to end with zero columns either side, so runs never
        # cross rows and 1-D operations find them all at once; then their 3-tap sums.
        self.score = np.zeros((rows, width + 2 * _PAD), np.float32)
        self.sums = np.zeros(self.score.size, np.float32)


def _close_gaps(begin: list[int], end: list[int], span: int) -> tuple[list[int], list[int]]:
    """Runs split by gaps of up to _GAP_PX within a row, joined."""
    joined_begin, joined_end = [begin[0]], [end[0]]
    for b, e in zip(begin[1:], end[1:], strict=True):
        last = joined_end[-1]
        if b - last <= _GAP_PX and b // span == last // span:
            joined_end[-1] = e
        else:
            joined_begin.append(b)
            joined_end.append(e)
    return joined_begin, joined_end


def _background(value: Plane, closing: int) -> Plane:
    """The floor's brightness along each row without the line.

    A morphological closing (``cv2.MORPH_CLOSE``: removes dark lines) or opening (removes
    bright ones) wider than a line, on 8-pixel block means smoothed over three blocks, each
    block's value spread over its pixels: it follows uneven light, costs little and ignores
    sensor noise. (Interpolating between blocks instead changes the floor by 0.4 % on
    average under strong uneven light, the position by under 0.01 px, and costs more than
    the rest of the background.)
    """
    k, width = value.shape
    blocks = _blocks(width)
    widths = _block_widths(width, blocks)
    if isinstance(widths, int):  # INTER_AREA: each block's mean, rounded half to even
        means = cv2.resize(value, (blocks, k), interpolation=cv2.INTER_AREA)
    else:  # plain means (INTER_AREA would weigh pixels shared by two blocks)
        starts = np.concatenate(([0], np.cumsum(widths)[:-1]))
        means = np.rint(np.add.reduceat(value, starts, axis=1, dtype=np.int64) / widths)
    coarse = np.maximum(means, 1, dtype=np.float32)  # the score divides by it
    smooth = cv2.blur(cv2.morphologyEx(coarse, closing, _kernel(_window(blocks))), (3, 1))
    out: Plane = np.repeat(smooth, widths, axis=1)
    return out


@functools.lru_cache(maxsize=8)
def _block_widths(width: int, blocks: int) -> int | npt.NDArray[np.intp]:
    """Pixels in each of ``blocks`` blocks across ``width`` (one number when they are all
    alike: np.repeat copies a third faster then)."""
    if width % blocks == 0:
        return width // blocks
    edges = np.round(np.linspace(0, width, blocks + 1)).astype(np.intp)
    widths: npt.NDArray[np.intp] = edges[1:] - edges[:-1]
    return widths


@functools.lru_cache(maxsize=8)
def _kernel(size: int) -> npt.NDArray[np.uint8]:
    return np.ones((1, size), np.uint8)


def _reduce(op: Callable[[Any, Any], Any], planes: list[Plane]) -> Plane:
    out = planes[0]
    for plane in planes[1:]:
        out = op(out, plane)
    return out
