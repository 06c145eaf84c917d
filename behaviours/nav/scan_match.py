"""Scan-to-map registration: a correlative search over a likelihood field, coarse to fine,
polished by point-to-line ICP, and honest about ambiguity.

The search is Olson's real-time correlative scan matching as Cartographer's
``fast_correlative_scan_matcher_2d`` lays it out: the likelihood field ``exp(-d^2/2 sigma^2)``
of the map, and a precomputed grid holding in each cell the maximum of the field over the
``coarse_cells`` x ``coarse_cells`` block that starts there, so a coarse candidate's score
bounds the scores of every translation inside its block. Coarse candidates are scored at every
heading step (translations as whole cell offsets: a rotated scan is turned into cell indices
once per heading), then refined best first at full resolution until the next coarse bound is
below the best full score (branch and bound, one level), capped at ``max_refinements``.

Honesty: a fit counts only when its score clears ``min_score`` and beats the best clearly
different pose (farther than ``distinct_m`` or ``distinct_rad``), also refined and polished,
by ``margin``. A symmetric room gives two poses of equal score: that is reported as ambiguous,
never as a confident fit. Scores are the mean over the scan's points of ``exp(-d^2/2 sigma^2)``
with ``d`` the exact distance to the nearest wall segment (after ICP), less the share of beams
that would have passed through a mapped wall (unmapped furniture only shortens beams, so a
pose that explains furniture as walls is caught by the walls it sees through).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from behaviours.nav.distance_field import DistanceField
from behaviours.nav.icp import Pose, Walls, icp, through_walls, wall_score

FloatArray = npt.NDArray[np.float64]
Area = tuple[float, float, float, float]
MAX_POINT_RANGE_M = 12.0
"""Scan points farther than this from the robot are not used (the LD19 reaches 12 m)."""


@dataclass(frozen=True, slots=True)
class MatchConfig:
    sigma_m: float = 0.05
    """Width of the likelihood field (the scan noise plus the map's cell)."""
    coarse_cells: int = 4
    """The precomputed grid's block: coarse translations step by this many cells."""
    coarse_step_rad: float = math.radians(1.5)
    search_points: int = 160
    """Scan points the search scores (evenly picked); ICP and the score use them all."""
    max_refinements: int = 48
    min_score: float = 0.5
    margin: float = 0.08
    distinct_m: float = 0.5
    distinct_rad: float = math.radians(30)


@dataclass(frozen=True, slots=True)
class Coarse:
    scores: npt.NDArray[np.float32]
    thetas: FloatArray
    offs_r: npt.NDArray[np.intp]
    offs_c: npt.NDArray[np.intp]
    order: npt.NDArray[np.intp]


@dataclass(frozen=True, slots=True)
class ScanFit:
    """The outcome of a fit: the pose, its score, the best clearly different pose's score."""

    pose: Pose
    score: float
    rival_score: float
    rival_pose: Pose | None
    accepted: bool
    reason: str
    """Why it was refused (empty when accepted): low score, or ambiguous with its rival."""
    candidates: int


def _wrap(angle: float) -> float:
    return math.atan2(math.sin(angle), math.cos(angle))


def distinct(a: Pose, b: Pose, distinct_m: float, distinct_rad: float) -> bool:
    return (math.hypot(a[0] - b[0], a[1] - b[1]) > distinct_m
            or abs(_wrap(a[2] - b[2])) > distinct_rad)


class ScanMatcher:
    """Fits scans to one map. Build once per map: the field and its block maxima are reused."""

    def __init__(self, field: DistanceField, walls: FloatArray,
                 config: MatchConfig | None = None) -> None:
        self.config = config or MatchConfig()
        c = self.config
        grid = field.grid
        self.resolution_m = grid.resolution_m
        self.origin = (grid.origin_x_m, grid.origin_y_m)
        d = np.minimum(field.distance_m.astype(np.float64), 10.0)
        fine = np.exp(-(d * d) / (2 * c.sigma_m * c.sigma_m)).astype(np.float32)
        coarse = _block_max(fine, c.coarse_cells)
        # Zero margins wide enough for any kept point from any candidate: no bounds checks
        # in the gathers (scan points past MAX_POINT_RANGE_M are dropped).
        self.pad = math.ceil((MAX_POINT_RANGE_M + 1.0) / self.resolution_m) + c.coarse_cells
        self.fine = np.pad(fine, self.pad)
        self.coarse = np.pad(coarse, self.pad)
        self.rows, self.cols = fine.shape
        self.walls = Walls.of(walls)

    def fit_local(self, points: FloatArray, guess: Pose, *, window_m: float = 0.35,
                  window_rad: float = math.radians(22), distinct_m: float = 0.2,
                  distinct_rad: float = math.radians(10)) -> ScanFit:
        """Fit near a guess (the robot roughly knows where it is)."""
        area = (guess[0] - window_m, guess[1] - window_m, guess[0] + window_m,
                guess[1] + window_m)
        return self._fit(points, area, guess[2], window_rad, distinct_m, distinct_rad)

    def fit_global(self, points: FloatArray, area: Area) -> ScanFit:
        """Fit anywhere in ``area`` (x0, y0, x1, y1) at any heading."""
        c = self.config
        return self._fit(points, area, 0.0, math.pi, c.distinct_m, c.distinct_rad)

    def _fit(self, points: FloatArray, area: Area, theta0: float, window_rad: float,
             distinct_m: float, distinct_rad: float) -> ScanFit:
        c = self.config
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        pts = pts[np.all(np.isfinite(pts), axis=1)]
        pts = pts[np.hypot(pts[:, 0], pts[:, 1]) <= MAX_POINT_RANGE_M]
        if pts.shape[0] < 10:
            return ScanFit((math.nan, math.nan, math.nan), 0.0, 0.0, None, False,
                           f"too few scan points ({pts.shape[0]})", 0)
        pick = pts[np.linspace(0, pts.shape[0] - 1, min(c.search_points, pts.shape[0]))
                   .astype(np.intp)]
        steps = max(1, math.ceil(window_rad / c.coarse_step_rad))
        if window_rad >= math.pi:
            thetas = np.arange(-math.pi, math.pi, c.coarse_step_rad)
        else:
            thetas = theta0 + c.coarse_step_rad * np.arange(-steps, steps + 1)
        coarse = self._coarse(pick, area, thetas)
        best_pose, best_score, count = self._branch(pts, pick, coarse, None, distinct_m,
                                                    distinct_rad)
        rival_pose, rival_score, more = self._branch(pts, pick, coarse, best_pose, distinct_m,
                                                     distinct_rad)
        count += more
        if rival_score > best_score:
            # The search ranks by likelihood alone; the full score (beams through walls
            # count against a pose) may prefer the rival: it is then the fit.
            best_pose, rival_pose = rival_pose, best_pose
            best_score, rival_score = rival_score, best_score
        accepted, reason = True, ""
        if best_score < c.min_score:
            accepted, reason = False, (f"score {best_score:.2f} below fit_min_score "
                                       f"{c.min_score:.2f}")
        elif best_score - rival_score < c.margin:
            accepted = False
            reason = (f"ambiguous: score {best_score:.2f} and {rival_score:.2f} at a clearly "
                      f"different pose ({_show(rival_pose)}) differ by less than "
                      f"{c.margin:.2f}")
        return ScanFit(best_pose, best_score, rival_score, rival_pose, accepted, reason, count)

    def _coarse(self, pick: FloatArray, area: Area, thetas: FloatArray) -> Coarse:
        """Every coarse candidate's bound: scores[heading, row block, col block]."""
        res, w = self.resolution_m, self.config.coarse_cells
        ox, oy = self.origin
        col0 = math.floor((area[0] - ox) / res)
        row0 = math.floor((area[1] - oy) / res)
        ncols = max(1, math.ceil((area[2] - area[0]) / (res * w)))
        nrows = max(1, math.ceil((area[3] - area[1]) / (res * w)))
        offs_r = np.clip(row0 + w * np.arange(nrows), -w, self.rows)
        offs_c = np.clip(col0 + w * np.arange(ncols), -w, self.cols)
        scores = np.zeros((thetas.shape[0], nrows, ncols), dtype=np.float32)
        for k, theta in enumerate(thetas):
            ct, st = math.cos(theta), math.sin(theta)
            # Scan points relative to the candidate's cell corner, in cells (floor per point).
            px = (ct * pick[:, 0] - st * pick[:, 1]) / res
            py = (st * pick[:, 0] + ct * pick[:, 1]) / res
            r = np.floor(py).astype(np.intp)[None, None, :] + (offs_r + self.pad)[:, None, None]
            q = np.floor(px).astype(np.intp)[None, None, :] + (offs_c + self.pad)[None, :, None]
            scores[k] = self.coarse[r, q].mean(axis=2)
        order = np.argsort(-scores, axis=None, kind="stable")
        return Coarse(scores, thetas, offs_r, offs_c, order)

    def _branch(self, pts: FloatArray, pick: FloatArray, coarse: Coarse,
                away_from: Pose | None, distinct_m: float, distinct_rad: float
                ) -> tuple[Pose, float, int]:
        """Best refined and polished pose among the coarse candidates (only those clearly
        different from ``away_from`` when given); (pose, score, refinements)."""
        c = self.config
        best_fine, best_pose = -1.0, None
        tried = 0
        flat = coarse.scores.ravel()
        for index in coarse.order:
            bound = float(flat[index])
            if bound < best_fine or tried >= c.max_refinements or bound <= 0.0:
                break
            k, i, j = np.unravel_index(int(index), coarse.scores.shape)
            theta = float(coarse.thetas[k])
            row, col = int(coarse.offs_r[i]), int(coarse.offs_c[j])
            centre = self._pose_of(theta, row, col, c.coarse_cells / 2)
            if away_from is not None and not distinct(centre, away_from, distinct_m,
                                                      distinct_rad):
                continue
            tried += 1
            fine_score, pose = self._refine(pick, theta, row, col)
            if fine_score > best_fine:
                best_fine, best_pose = fine_score, pose
        if best_pose is None:
            return ((math.nan, math.nan, math.nan), 0.0, tried)
        polished = icp(pts, self.walls, best_pose)
        if away_from is not None and not distinct(polished, away_from, distinct_m,
                                                  distinct_rad):
            polished = best_pose  # ICP slid onto the best fit: score the candidate itself
        return (polished, self.score(pts, polished), tried)

    def score(self, points: FloatArray, pose: Pose) -> float:
        """The fit's score at a pose: the points' mean likelihood by their exact distance to
        the walls, less the share of beams that would have passed through a wall."""
        return (wall_score(points, self.walls, pose, self.config.sigma_m)
                - through_walls(points, self.walls, pose))

    def _refine(self, pick: FloatArray, theta: float, row: int, col: int
                ) -> tuple[float, Pose]:
        """The best full-resolution candidate inside a coarse block (headings within half a
        coarse step either way)."""
        res, w = self.resolution_m, self.config.coarse_cells
        ths = theta + self.config.coarse_step_rad * np.array([-0.5, 0.0, 0.5])
        ct, st = np.cos(ths)[:, None], np.sin(ths)[:, None]
        px = (ct * pick[:, 0] - st * pick[:, 1]) / res
        py = (st * pick[:, 0] + ct * pick[:, 1]) / res
        offs = np.arange(w)
        r = np.floor(py).astype(np.intp)[:, None, None, :] + (row + self.pad + offs)[
            None, :, None, None]
        q = np.floor(px).astype(np.intp)[:, None, None, :] + (col + self.pad + offs)[
            None, None, :, None]
        scores = self.fine[r, q].mean(axis=3)
        a, i, j = np.unravel_index(int(np.argmax(scores)), scores.shape)
        return float(scores[a, i, j]), self._pose_of(float(ths[a]), row + int(i),
                                                     col + int(j), 0.0)

    def _pose_of(self, theta: float, row: int, col: int, cells: float) -> Pose:
        """The map-frame pose of a candidate: the robot at the corner of cell (row, col)
        (a scan point's cell is floor(point / res) + offset), plus ``cells`` in x and y."""
        res = self.resolution_m
        return (self.origin[0] + (col + cells) * res, self.origin[1] + (row + cells) * res,
                _wrap(theta))


def _block_max(field: npt.NDArray[np.float32], width: int) -> npt.NDArray[np.float32]:
    """Each cell: the maximum over the ``width`` x ``width`` block starting at it (cells past
    the edge count as 0), as Cartographer's precomputation grid."""
    rows, cols = field.shape
    padded = np.zeros((rows + width, cols + width), dtype=np.float32)
    padded[:rows, :cols] = field
    along = padded[:, :cols].copy()
    for k in range(1, width):
        np.maximum(along, padded[:, k:k + cols], out=along)
    out = along[:rows].copy()
    for k in range(1, width):
        np.maximum(out, along[k:k + rows], out=out)
    return out


def _show(pose: Pose | None) -> str:
    if pose is None:
        return "none"
    return f"{pose[0]:.2f}, {pose[1]:.2f}, {math.degrees(pose[2]):.0f} deg"
