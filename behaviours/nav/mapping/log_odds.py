"""The occupancy grid rendered from scans at their (optimised) poses: log-odds ray casting.

Each beam lowers the log odds of the cells it passes through (``free_logodds``) and raises
that of the cell it ends in (``hit_logodds``), clamped, as GMapping's and Cartographer's
probability grids do; a beam with no return clears nothing (it may have passed a glass door
or a wall at a grazing angle). A cell is counted once per scan for each of the two updates,
so a scan's many beams near the robot do not outvote what other scans saw. The result is a
map_server trinary map: occupied above ``occupied_thresh``, free below ``free_thresh``
(``map_saver``'s 0.65 and 0.25), unknown between and where no beam went.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from behaviours.nav.icp import Pose, transform
from behaviours.nav.mapping.scan import Scan
from hal.occupancy_map import FREE, OCCUPIED, UNKNOWN, OccupancyMap

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class RenderConfig:
    resolution_m: float = 0.05
    hit_logodds: float = 0.85
    free_logodds: float = -0.4
    clamp_logodds: float = 3.5
    max_range_m: float = 12.0
    """Returns farther than this are not drawn (beyond it one degree spans 20 cm)."""
    occupied_thresh: float = 0.65
    free_thresh: float = 0.25
    margin_m: float = 1.0


def render(scans: Sequence[Scan], poses: Sequence[Pose], config: RenderConfig | None = None
           ) -> OccupancyMap:
    """The trinary map of ``scans`` placed at ``poses`` (robot poses in the map frame)."""
    c = config or RenderConfig()
    res = c.resolution_m
    worlds = [place(scan, pose, c) for scan, pose in zip(scans, poses, strict=True)]
    every = np.vstack([w for _, w in worlds] + [s[None, :] for s, _ in worlds])
    x0 = math.floor((float(every[:, 0].min()) - c.margin_m) / res) * res
    y0 = math.floor((float(every[:, 1].min()) - c.margin_m) / res) * res
    cols = math.ceil((float(every[:, 0].max()) + c.margin_m - x0) / res) + 1
    rows = math.ceil((float(every[:, 1].max()) + c.margin_m - y0) / res) + 1
    logodds = np.zeros(rows * cols, dtype=np.float32)
    seen = np.zeros(rows * cols, dtype=np.bool_)
    for sensor, pts in worlds:
        accumulate(logodds, seen, sensor, pts, x0, y0, cols, c)
    return OccupancyMap(trinary(logodds, seen, c).reshape(rows, cols), res, x0, y0, "mapping")


def place(scan: Scan, pose: Pose, c: RenderConfig) -> tuple[FloatArray, FloatArray]:
    """The sensor's position and the scan's returns (within ``max_range_m``) in the map."""
    pts = scan.points()
    if pts.shape[0]:
        pts = pts[np.hypot(pts[:, 0], pts[:, 1]) <= c.max_range_m]
    sensor = transform(np.asarray([scan.laser_offset[:2]], dtype=np.float64), pose)[0]
    return sensor, transform(pts, pose)


def accumulate(logodds: npt.NDArray[np.float32], seen: npt.NDArray[np.bool_],
               sensor: FloatArray, pts: FloatArray, x0: float, y0: float, cols: int,
               c: RenderConfig) -> None:
    """One scan's beams into flat (row-major, ``cols`` wide) log odds and seen arrays."""
    if pts.shape[0] == 0:
        return
    res = c.resolution_m
    hit = _cells(pts[:, 0], pts[:, 1], x0, y0, res, cols)
    passed = _beam_cells(sensor, pts, x0, y0, res, cols)
    passed = np.setdiff1d(passed, hit, assume_unique=False)
    hit = np.unique(hit)
    logodds[passed] += c.free_logodds
    logodds[hit] += c.hit_logodds
    np.clip(logodds, -c.clamp_logodds, c.clamp_logodds, out=logodds)
    seen[passed] = True
    seen[hit] = True


def trinary(logodds: npt.NDArray[np.float32], seen: npt.NDArray[np.bool_], c: RenderConfig
            ) -> npt.NDArray[np.int8]:
    """``FREE``, ``OCCUPIED`` or ``UNKNOWN`` per cell, by ``map_saver``'s thresholds."""
    p = 1.0 - 1.0 / (1.0 + np.exp(logodds.astype(np.float64)))
    cells = np.full(logodds.shape, UNKNOWN, dtype=np.int8)
    cells[seen & (p < c.free_thresh)] = FREE
    cells[seen & (p > c.occupied_thresh)] = OCCUPIED
    return cells


def _cells(x: FloatArray, y: FloatArray, x0: float, y0: float, res: float, cols: int
           ) -> npt.NDArray[np.intp]:
    r = np.floor((y - y0) / res).astype(np.intp)
    q = np.floor((x - x0) / res).astype(np.intp)
    return r * cols + q


def _beam_cells(sensor: FloatArray, pts: FloatArray, x0: float, y0: float, res: float,
                cols: int) -> npt.NDArray[np.intp]:
    """The cells the beams cross before their end (sampled every half cell), once each."""
    d = pts - sensor[None, :]
    length = np.hypot(d[:, 0], d[:, 1])
    steps = np.maximum(1, np.ceil(length / (res / 2)).astype(np.intp))
    total = int(steps.sum())
    beam = np.repeat(np.arange(pts.shape[0]), steps)
    start = np.repeat(np.cumsum(steps) - steps, steps)
    frac = (np.arange(total) - start) / np.repeat(steps, steps)
    # Stop a cell short of the end: the end cell is the hit's.
    frac = frac * np.maximum(0.0, 1.0 - res / np.maximum(length, 1e-9))[beam]
    x = sensor[0] + d[beam, 0] * frac
    y = sensor[1] + d[beam, 1] * frac
    return np.unique(_cells(x, y, x0, y0, res, cols))
