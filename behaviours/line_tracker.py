"""Where the painted line is in a camera frame: position error in pixels, confidence, lost.

The tracker reads a few scan rows across a region of interest instead of the whole frame. Each
row gets a per-pixel score for the wanted colour, divided by the local floor brightness (the
row with the line closed over), so light that falls off to the corners or varies over the
floor does not move the line. Runs of high score are line candidates; when there are several,
one line is picked (nearest the previous position) and each row keeps its run of it. A
row's position is halfway between its run's edges, each where the score crosses the
threshold, interpolated between two pixels; the line's position is the mean over the rows
that found it, at their mean row (the median when one row is off the others).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np
import numpy.typing as npt

from behaviours.line_colours import DEFAULT_COLOUR, LineColour, line_colour, parse_colour

# Contrast needed, as a multiple of TrackerParams.min_contrast: a grey line on a grey floor
# differs less than a coloured one, and dark shadows must not pass for a black line.
_THRESHOLD_SCALE = {"dark": 1.5, "light": 0.5, "chroma": 1.0}
Plane = npt.NDArray[Any]  # float32 rows (cv2 returns loosely typed arrays)

_TOO_DARK = 20.0  # floor brightness (grey levels) below which nothing can be seen
_GREY_TINT = 24  # channel spread (grey levels) a grey surface shows from noise and light
_BACKGROUND_FRAC = 0.17  # background window, fraction of the width: wider than any line
_GAP_PX = 3  # gaps this narrow inside a run are noise
_OFF_LINE_PX = 0.5  # mean this far from the median: a row is off the line
_PAD = 2  # zero columns either side of each row, so runs never cross rows
_MAX_WORK_PX = 640  # wider frames are averaged over 2 (3...) columns: same answer, less work


@dataclass(frozen=True, slots=True)
class LineReading:
    """One frame's verdict. ``error_px`` > 0: the line is right of the image centre."""

    error_px: float
    confidence: float
    lost: bool
    x_px: float | None = None
    width_px: float = 0.0
    at_edge: bool = False
    candidates: int = 0
    colour: str = DEFAULT_COLOUR
    reason: str = ""
    row_px: float = 0.0  # the image row the position refers to (mean of the rows used)


@dataclass(frozen=True, slots=True)
class TrackerParams:
    """Region of interest (fractions of the height, 0 = top = farthest ahead) and thresholds."""

    roi_top: float = 0.25
    roi_bottom: float = 0.6
    rows: int = 8
    min_contrast: float = 0.2
    min_width_frac: float = 0.01
    max_width_frac: float = 0.5
    handover_frames: int = 26  # old colour still followed after a change, about 2 s at 13 FPS

    def __post_init__(self) -> None:
        if not 0.0 <= self.roi_top < self.roi_bottom <= 1.0:
            msg = f"line tracker ROI {self.roi_top}-{self.roi_bottom}: need 0 <= top < bottom <= 1"
            raise ValueError(msg)
        if self.rows < 1:
            msg = f"line tracker rows must be >= 1, got {self.rows}"
            raise ValueError(msg)


class LineTracker:
    """Finds the line of one colour in BGR frames; remembers where it was last seen.

    Args:
        params: region of interest and thresholds.
        colour: the colour to follow (a FollowColor name or ``#RRGGBB``; None: dark line).
    """

    def __init__(self, params: TrackerParams | None = None, colour: str | None = None) -> None:
        self.params = params or TrackerParams()
        self._colour = line_colour(parse_colour(colour))
        self._fallback: LineColour | None = None
        self._handover_left = 0
        self._last_x: float | None = None
        self._misses = 0
        self._picks_height = 0  # the frame height the scan rows were picked for (0: none)
        self._picks = np.zeros(0, np.intp)
        self._pick_rows: list[int] = []
        self._work = _Workspace(0, 0)

    @property
    def colour(self) -> str:
        return self._colour.name

    def set_colour(self, name: str | None) -> None:
        """Follow another colour; the old one is still taken until the new one shows up."""
        new = line_colour(parse_colour(name))
        if new.name == self._colour.name:
            return
        self._fallback = self._colour
        self._handover_left = self.params.handover_frames
        self._colour = new

    def set_params(self, params: TrackerParams) -> None:
        """Take new ROI and thresholds (live tuning)."""
        self.params = params
        self._picks_height = 0

    def reset(self) -> None:
        """Forget the last position (a new run starts from the image centre)."""
        self._last_x = None
        self._misses = 0

    def track(self, image: npt.NDArray[np.uint8]) -> LineReading:
        """Find the line in one BGR frame."""
        if image.ndim != 3 or image.shape[2] != 3 or image.shape[0] < 2 or image.shape[1] < 8:
            msg = f"line tracker: expected a BGR image (h, w, 3), got shape {image.shape}"
            raise ValueError(msg)
        planes, step = self._strip(image)
        reading = self._find(planes, step, self._colour, image.shape[1])
        if reading.lost and self._fallback is not None and self._handover_left > 0:
            reading = self._find(planes, step, self._fallback, image.shape[1])
        if self._fallback is not None:
            self._handover_left -= 1
            if self._handover_left <= 0 or (not reading.lost and reading.colour == self.colour):
                self._fallback = None
        if reading.lost:
            self._misses += 1
        else:
            self._last_x = reading.x_px
            self._misses = 0
        return reading

    # --- internals ----------------------------------------------------------------------------
    def _strip(self, image: npt.NDArray[np.uint8]) -> tuple[list[Plane], int]:
        """The scan rows as uint8 planes (B, G, R), at most _MAX_WORK_PX wide, and the step."""
        h, w = image.shape[:2]
        if self._picks_height != h:
            p = self.params
            top = min(h - 1, int(p.roi_top * h))
            bottom = max(top + 1, min(h, int(p.roi_bottom * h)))
            picks = np.linspace(top, bottom - 1, min(p.rows, bottom - top)).astype(np.intp)
            self._picks_height = h
            self._picks = picks
            self._pick_rows = picks.tolist()
        step = max(1, -(-w // _MAX_WORK_PX))
        rows: Plane = image[self._picks]
        if step > 1:  # mean of each column group: keeps sub-pixel detail, halves the noise
            rows = cv2.resize(rows, (w // step, rows.shape[0]), interpolation=cv2.INTER_AREA)
        k, width = rows.shape[:2]
        if self._work.shape != (k, width):
            self._work = _Workspace(k, width)
        cv2.split(rows, self._work.planes)
        return self._work.planes, step

    def _find(self, planes: list[Plane], step: int, colour: LineColour,
              full_width: int) -> LineReading:
        centre = (full_width - 1) / 2
        work = self._work
        raw = work.raw
        if colour.kind in ("dark", "light"):
            value = np.maximum(planes[0], planes[1], out=work.value)
            np.maximum(value, planes[2], out=value)
            floor = _background(value, cv2.MORPH_CLOSE)
            if float(cv2.mean(floor)[0]) < _TOO_DARK:
                return self._lost(centre, colour, "too dark")
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
            floor = _background(_reduce(cv2.max, planes), cv2.MORPH_CLOSE)
            if float(cv2.mean(floor)[0]) < _TOO_DARK:
                return self._lost(centre, colour, "too dark")
            wanted = _reduce(cv2.min, [planes[c] for c in colour.channels])
            others = _reduce(cv2.max, [planes[c] for c in (0, 1, 2) if c not in colour.channels])
            cv2.subtract(wanted, others, dst=raw, dtype=cv2.CV_32F)
        k, width = work.shape
        np.divide(raw, floor, out=work.score[:, _PAD:-_PAD])
        threshold = self.params.min_contrast * _THRESHOLD_SCALE[colour.kind]
        return self._pick(k, width, threshold, colour, step, full_width)

    def _pick(self, k: int, width: int, threshold: float, colour: LineColour,
              step: int, full_width: int) -> LineReading:
        p = self.params
        centre = (full_width - 1) / 2
        span = width + 2 * _PAD
        # Each cell plus its neighbours either side: a 3-tap sum that takes the edge off
        # sensor noise (hence 3 * threshold); the first and last cell stay 0.
        cells, flat = self._work.score.ravel(), self._work.sums
        inner = flat[1:-1]
        np.add(cells[:-2], cells[1:-1], out=inner)
        inner += cells[2:]
        above = flat > 3 * threshold
        change = (above[1:] != above[:-1]).nonzero()[0] + 1
        begin, end = change[0::2], change[1::2]
        bounds = change  # begin, end, begin, end...: reduceat's segment starts
        if begin.size > k:  # noise splits faint lines: close gaps of up to _GAP_PX
            join = (begin[1:] - end[:-1] <= _GAP_PX) & (begin[1:] // span == end[:-1] // span)
            begin = begin[np.concatenate(([True], ~join))]
            end = end[np.concatenate((~join, [True]))]
        run_w = end - begin
        narrowest, widest = max(2, p.min_width_frac * width), p.max_width_frac * width
        widths = run_w.tolist()  # a few runs: plain Python is cheaper than more array calls
        if widths and (min(widths) < narrowest or max(widths) > widest):
            keep = (run_w >= narrowest) & (run_w <= widest)
            begin, end, run_w = begin[keep], end[keep], run_w[keep]
            bounds = np.empty(0, np.intp)
        if begin.size == 0:
            return self._lost(centre, colour, "no line")
        row = begin // span
        rows = row.tolist()
        candidates = 1
        if len(set(rows)) < len(rows):  # a row with several runs
            candidates = int(np.bincount(row).max())
            near = self._last_x if self._last_x is not None and self._misses < 10 else centre
            chosen = _one_line(row, (begin + end - 1) / 2 - row * span - _PAD,
                               (near - (step - 1) / 2) / step, width / 8, (k + 2) // 3)
            begin, end, run_w, row = begin[chosen], end[chosen], run_w[chosen], row[chosen]
        found = begin.size
        if found < max(1, (k + 2) // 3):
            return self._lost(centre, colour, "too few rows")
        rows_px = self._pick_rows if found == k else self._picks[row].tolist()
        if bounds.size != 2 * found:
            bounds = np.empty(2 * found, np.intp)
            bounds[0::2], bounds[1::2] = begin, end
        mass = np.add.reduceat(flat, bounds)[0::2]  # > 0: every run is above the threshold
        # Where each run's sums cross the threshold, interpolated between the cells either
        # side of its begin and its end: the line's middle is halfway between the two. (A
        # centroid weighted by the score moved with any error of the floor across a wide
        # line under uneven light - 0.08 px mean error at 640 x 480 against 0.05 now.)
        before, at = flat[bounds - 1], flat[bounds]
        cross = (bounds - 1) + (3 * threshold - before) / (at - before)
        xs = (cross[0::2] + cross[1::2]) / 2 - (row * span + _PAD)
        x_px, row_px = _centre(xs.tolist(), rows_px, found == k)
        line_x = x_px * step + (step - 1) / 2
        line_w = _median_of(run_w.tolist()) * step
        # Seen cut off by the image border: its visible part's centre is within half its
        # width (plus the smoothing's spread) of the border.
        reach = line_w / 2 + 2 * step
        at_edge = line_x < reach or line_x > full_width - 1 - reach
        contrast = _median_of((mass / run_w).tolist()) / 3
        confidence = min(1.0, contrast / (2 * threshold)) * found / k
        if at_edge:
            confidence *= 0.6
        if candidates > 1:
            confidence *= 0.8
        return LineReading(line_x - centre, confidence, False, line_x, line_w, at_edge,
                           candidates, colour.name, "", row_px)

    def _lost(self, centre: float, colour: LineColour, reason: str) -> LineReading:
        last = 0.0 if self._last_x is None else self._last_x - centre
        return LineReading(last, 0.0, True, None, 0.0, False, 0, colour.name, reason)


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


def _one_line(row: npt.NDArray[np.intp], mid: Plane, near: float, reach: float,
              min_rows: int) -> npt.NDArray[np.intp]:
    """Runs of several lines: pick one line and its run in each row.

    The line is the one nearest ``near`` among runs that line up with runs in at least
    ``min_rows`` rows (within ``reach``), so a speck of noise is not a line; each row then
    keeps its run nearest that line, if within ``reach``. Choosing each row on its own
    could mix two lines into a position between them.
    """
    apart = np.abs(mid[:, None] - mid[None, :]) <= reach
    support = np.array([np.unique(row[m]).size for m in apart])
    lines = support >= min_rows
    pool = np.flatnonzero(lines) if lines.any() else np.arange(mid.size)
    anchor = float(mid[pool[np.argmin(np.abs(mid[pool] - near))]])
    distance = np.abs(mid - anchor)
    order = np.lexsort((distance, row))
    first = np.ones(order.size, bool)
    first[1:] = row[order][1:] != row[order][:-1]
    chosen = order[first]
    return np.sort(chosen[distance[chosen] <= reach])


def _centre(xs: list[float], rows: list[int], evenly: bool) -> tuple[float, float]:
    """Where the line is, and at which row: the mean over the rows, which is less noisy than
    the median - unless one row is off the others (a run cut short by glare or noise) and
    pulls the mean away from the median. Comparing them needs both at the same row: rows
    evenly spaced, all found."""
    mid_x = _median_of(xs)
    if evenly:
        mean_x = sum(xs) / len(xs)
        if abs(mean_x - mid_x) <= _OFF_LINE_PX:
            return mean_x, sum(rows) / len(rows)
    return mid_x, _median_of(rows)


def _median_of(values: list[float] | list[int]) -> float:
    ordered = sorted(values)
    n = len(ordered)
    return float(ordered[n // 2] if n % 2 else (ordered[n // 2 - 1] + ordered[n // 2]) / 2)


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
    blocks = max(4, width // 8)
    coarse = np.maximum(cv2.resize(value, (blocks, k), interpolation=cv2.INTER_AREA), 1,
                        dtype=np.float32)  # the score divides by it
    kernel = _kernel(max(3, round(blocks * _BACKGROUND_FRAC)) | 1)
    smooth = cv2.blur(cv2.morphologyEx(coarse, closing, kernel), (3, 1))
    out: Plane = np.repeat(smooth, _block_widths(width, blocks), axis=1)
    return out


@functools.lru_cache(maxsize=8)
def _block_widths(width: int, blocks: int) -> int | npt.NDArray[np.intp]:
    """Pixels in each of ``blocks`` INTER_AREA blocks across ``width`` (one number when they
    are all alike: np.repeat copies a third faster then)."""
    if width % blocks == 0:
        return width // blocks
    edges = np.round(np.linspace(0, width, blocks + 1)).astype(np.intp)
    widths: npt.NDArray[np.intp] = edges[1:] - edges[:-1]
    return widths


@functools.lru_cache(maxsize=8)
def _kernel(size: int) -> npt.NDArray[np.uint8]:
    return np.ones((1, size), np.uint8)


def _reduce(op: Callable[[Any, Any], Any], planes: list[Plane]
            ) -> Plane:
    out = planes[0]
    for plane in planes[1:]:
        out = op(out, plane)
    return out
