"""Where the painted line is in a camera frame: position error in pixels, confidence, lost.

The tracker reads a few scan rows across a region of interest instead of the whole frame;
behaviours/line/scan.py finds the runs of the wanted colour in them (the score against the
floor, the runs and their middles). When there are several runs in a row, one line is picked
(nearest the previous position) and each row keeps its run of it; the line's position is the
mean of the rows' middles, at their mean row (the median when one row is off the others).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

from behaviours.line.colours import DEFAULT_COLOUR, LineColour, line_colour, parse_colour
from behaviours.line.scan import Run, row_scan
from hal.readings import Frame

# Contrast needed, as a multiple of TrackerParams.min_contrast: a grey line on a grey floor
# differs less than a coloured one, and dark shadows must not pass for a black line.
_THRESHOLD_SCALE = {"dark": 1.5, "light": 0.5, "chroma": 1.0}

_TOO_DARK = 20.0  # floor brightness (grey levels) below which nothing can be seen
_OFF_LINE_PX = 0.5  # mean this far from the median: a row is off the line
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
        if not self.min_contrast > 0:
            msg = f"line tracker min_contrast must be > 0, got {self.min_contrast}"
            raise ValueError(msg)


class LineTracker:
    """Finds the line of one colour in BGR frames; remembers where it was last seen.

    Args:
        params: region of interest and thresholds.
        colour: the colour to follow (a FollowColor name or ``#RRGGBB``; None: dark line).
        kernel: how rows are scanned, "c" or "numpy" (None: ``ROBOTD_LINE_KERNEL`` if set,
            else C when it was built; see behaviours/line/scan.py).
    """

    def __init__(self, params: TrackerParams | None = None, colour: str | None = None,
                 kernel: str | None = None) -> None:
        self.params = params or TrackerParams()
        self._colour = line_colour(parse_colour(colour))
        self._fallback: LineColour | None = None
        self._handover_left = 0
        self._last_x: float | None = None
        self._misses = 0
        self._picks_height = 0  # the frame height the scan rows were picked for (0: none)
        self._pick_rows: list[int] = []
        self._scan = row_scan(kernel)

    @property
    def kernel(self) -> str:
        """How rows are scanned: "c" or "numpy"."""
        return self._scan.kernel

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

    def track(self, frame: Frame | npt.NDArray[np.uint8]) -> LineReading:
        """Find the line in one BGR frame (a Frame is asked for its scan rows only)."""
        shape = frame.shape
        if len(shape) != 3 or shape[2] != 3 or shape[0] < 2 or shape[1] < 8:
            msg = f"line tracker: expected a BGR image (h, w, 3), got shape {shape}"
            raise ValueError(msg)
        strip, rows = self._rows(frame, shape[0], shape[1])
        reading = self._find(strip, rows, self._colour, shape[1])
        if reading.lost and self._fallback is not None and self._handover_left > 0:
            reading = self._find(strip, rows, self._fallback, shape[1])
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
    def _rows(self, frame: Frame | npt.NDArray[np.uint8], h: int, w: int
              ) -> tuple[npt.NDArray[np.uint8], Sequence[int]]:
        """The scan rows' pixels (the whole image, or a strip of just those rows, averaged down
        to at most _MAX_WORK_PX wide) and the scan rows in it. The scan reads each row on its
        own, so a strip gives the runs the whole image gives."""
        if self._picks_height != h:
            p = self.params
            top = min(h - 1, int(p.roi_top * h))
            bottom = max(top + 1, min(h, int(p.roi_bottom * h)))
            picks = np.linspace(top, bottom - 1, min(p.rows, bottom - top)).astype(np.intp)
            self._picks_height = h
            self._pick_rows = picks.tolist()
        step = -(-w // _MAX_WORK_PX)
        if step == 1 and not isinstance(frame, Frame):
            return frame, self._pick_rows
        # A frame draws just the rows asked for (a simulated camera renders only those).
        strip = frame.rows(self._pick_rows) if isinstance(frame, Frame) else frame[
            self._pick_rows]
        if step == 1:
            return strip, range(len(self._pick_rows))
        # The mean of each column group keeps sub-pixel detail and halves the noise.
        rows = cv2.resize(strip, (w // step, len(self._pick_rows)),
                          interpolation=cv2.INTER_AREA).astype(np.uint8, copy=False)
        return rows, range(len(self._pick_rows))

    def _find(self, image: npt.NDArray[np.uint8], rows: Sequence[int], colour: LineColour,
              full_width: int) -> LineReading:
        threshold = self.params.min_contrast * _THRESHOLD_SCALE[colour.kind]
        # 3 * threshold: the runs are of 3-tap sums
        floor, runs = self._scan.scan(image, rows, colour, 3 * threshold)
        if floor < _TOO_DARK:
            return self._lost((full_width - 1) / 2, colour, "too dark")
        return self._pick(runs, len(rows), image.shape[1], threshold, colour, full_width)

    def _pick(self, runs: list[Run], k: int, width: int, threshold: float, colour: LineColour,
              full_width: int) -> LineReading:
        p = self.params
        centre = (full_width - 1) / 2
        scale = full_width / width  # frame pixels per work column (wide frames averaged down)
        narrowest, widest = max(2, p.min_width_frac * width), p.max_width_frac * width
        runs = [run for run in runs if narrowest <= run[2] - run[1] <= widest]
        if not runs:
            return self._lost(centre, colour, "no line")
        row = [run[0] for run in runs]
        candidates = 1
        if len(set(row)) < len(row):  # a row with several runs
            candidates = max(row.count(r) for r in set(row))
            near = self._last_x if self._last_x is not None and self._misses < 10 else centre
            chosen = _one_line(row, [(b + e - 1) / 2 for _, b, e, _, _ in runs],
                               (near + 0.5) / scale - 0.5, width / 8, (k + 2) // 3)
            runs = [runs[i] for i in chosen]
            row = [run[0] for run in runs]
        found = len(runs)
        if found < max(1, (k + 2) // 3):
            return self._lost(centre, colour, "too few rows")
        rows_px = self._pick_rows if found == k else [self._pick_rows[r] for r in row]
        # Each run's middle is halfway between where its sums cross the level at its begin
        # and its end. (A centroid weighted by the score moved with any error of the floor
        # across a wide line under uneven light - 0.08 px mean error at 640 x 480 against
        # 0.05.)
        x_px, row_px = _centre([run[3] for run in runs], rows_px, found == k)
        line_x = (x_px + 0.5) * scale - 0.5
        widths = [e - b for _, b, e, _, _ in runs]
        line_w = _median_of(widths) * scale
        # Seen cut off by the image border: its visible part's centre is within half its
        # width (plus the smoothing's spread) of the border.
        reach = line_w / 2 + 2 * scale
        at_edge = line_x < reach or line_x > full_width - 1 - reach
        contrast = _median_of([run[4] / w for run, w in zip(runs, widths, strict=True)]) / 3
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


def _one_line(row: list[int], mid: list[float], near: float, reach: float,
              min_rows: int) -> list[int]:
    """Runs of several lines: pick one line and its run in each row.

    The line is the one nearest ``near`` among runs that line up with runs in at least
    ``min_rows`` rows (within ``reach``), so a speck of noise is not a line; each row then
    keeps its run nearest that line, if within ``reach``. Choosing each row on its own
    could mix two lines into a position between them.
    """
    # A few dozen runs at most: plain Python (numpy's per-call cost made this 0.2 ms).
    runs = range(len(mid))
    support = [len({row[j] for j in runs if abs(mid[j] - mid[i]) <= reach}) for i in runs]
    pool = [i for i in runs if support[i] >= min_rows] or list(runs)
    anchor = mid[min(pool, key=lambda i: abs(mid[i] - near))]
    nearest: dict[int, int] = {}  # row -> its run nearest the anchor, within reach
    for i in runs:
        distance = abs(mid[i] - anchor)
        if distance <= reach and (row[i] not in nearest
                                  or distance < abs(mid[nearest[row[i]]] - anchor)):
            nearest[row[i]] = i
    return sorted(nearest.values())


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
