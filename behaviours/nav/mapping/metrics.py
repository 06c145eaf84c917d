"""How good a map is: the relation metric of Kümmerle et al. 2009 and cells against a truth.

Relation metric ("On measuring the accuracy of SLAM algorithms", Auton. Robots 27, 2009):
for pairs (i, j) of poses, the relative motion the estimate gives, ``between(x_i, x_j)``, is
compared with the true one, ``between(x*_i, x*_j)``; the error of a pair is
``between(true, estimated)``, whose translation and rotation are averaged over the pairs. It
does not depend on the frame either trajectory is in. ``pairs="consecutive"`` takes (i, i+1)
(local accuracy, as the published tables for the Intel lab), ``"all"`` every i < j (global
consistency: a bent map shows here).

Map quality: of the cells the map knows (free or occupied), the share of its occupied cells
within one cell of a true occupied cell, and the share of its free cells that are free in the
truth; both maps in one frame, at any resolutions.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

from behaviours.nav.icp import Pose
from hal.occupancy_map import FREE, OCCUPIED, OccupancyMap

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.intp]


@dataclass(frozen=True, slots=True)
class RelationError:
    translation_m: float
    rotation_rad: float
    translation_max_m: float
    rotation_max_rad: float
    pairs: int


def relation_error(estimated: Sequence[Pose], true: Sequence[Pose], *,
                   pairs: str = "consecutive") -> RelationError:
    """Mean (and worst) relation error between two trajectories of the same poses."""
    if len(estimated) != len(true) or len(true) < 2:
        msg = (f"need two trajectories of the same length >= 2, got {len(estimated)} and "
               f"{len(true)}")
        raise ValueError(msg)
    e = np.asarray(estimated, dtype=np.float64)
    t = np.asarray(true, dtype=np.float64)
    n = len(true)
    if pairs == "consecutive":
        i, j = np.arange(n - 1), np.arange(1, n)
    elif pairs == "all":
        i, j = np.triu_indices(n, k=1)
    else:
        msg = f"pairs: expected 'consecutive' or 'all', got {pairs!r}"
        raise ValueError(msg)
    de = _between(e[i], e[j])
    dt = _between(t[i], t[j])
    err = _between(dt, de)
    trans = np.hypot(err[:, 0], err[:, 1])
    rot = np.abs(err[:, 2])
    return RelationError(float(trans.mean()), float(rot.mean()), float(trans.max()),
                         float(rot.max()), int(i.size))


def _between(a: FloatArray, b: FloatArray) -> FloatArray:
    c, s = np.cos(a[:, 2]), np.sin(a[:, 2])
    dx, dy = b[:, 0] - a[:, 0], b[:, 1] - a[:, 1]
    dth = np.arctan2(np.sin(b[:, 2] - a[:, 2]), np.cos(b[:, 2] - a[:, 2]))
    out: FloatArray = np.column_stack((c * dx + s * dy, -s * dx + c * dy, dth))
    return out


@dataclass(frozen=True, slots=True)
class MapQuality:
    occupied_near_wall_pct: float
    free_truly_free_pct: float
    occupied_cells: int
    free_cells: int


def map_quality(estimated: OccupancyMap, true: OccupancyMap, *, near_cells: int = 1
                ) -> MapQuality:
    """Occupied cells within ``near_cells`` true cells of a true wall, free cells truly free
    (cells of the estimate that fall outside the truth count as wrong)."""
    true_occ = (true.cells == OCCUPIED).astype(np.uint8)
    size = 2 * near_cells + 1
    near = cv2.dilate(true_occ, np.ones((size, size), np.uint8)).astype(bool)
    truly_free = true.cells == FREE
    res = estimated.resolution_m

    def lookup(mask: BoolArray, rows: IntArray, cols: IntArray) -> BoolArray:
        y = estimated.origin_y_m + (rows + 0.5) * res
        x = estimated.origin_x_m + (cols + 0.5) * res
        r = np.floor((y - true.origin_y_m) / true.resolution_m).astype(np.intp)
        q = np.floor((x - true.origin_x_m) / true.resolution_m).astype(np.intp)
        inside = (r >= 0) & (r < true.height) & (q >= 0) & (q < true.width)
        out: BoolArray = np.zeros(rows.shape, dtype=np.bool_)
        out[inside] = mask[r[inside], q[inside]]
        return out

    occ_r, occ_c = np.nonzero(estimated.cells == OCCUPIED)
    free_r, free_c = np.nonzero(estimated.cells == FREE)
    occ_ok = lookup(near, occ_r, occ_c)
    free_ok = lookup(truly_free, free_r, free_c)
    return MapQuality(_pct(occ_ok), _pct(free_ok), int(occ_r.size), int(free_r.size))


def _pct(ok: BoolArray) -> float:
    return 100.0 * float(ok.mean()) if ok.size else math.nan
