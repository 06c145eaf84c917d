"""The occupancy grid of a map being made live: each key scan ray cast in once, as it comes.

``render`` (``log_odds``) places every scan again from the optimised poses, which takes seconds
on a site; the live map only adds the newest key scan (tens of milliseconds) and grows by
whole blocks of ``block_m`` when a scan reaches past its edge. After a loop closure the poses
move: ``rebuild`` casts every key scan again from the optimised poses. The cells it reads out
are the same trinary cells a saved map has.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from behaviours.nav.icp import Pose
from behaviours.nav.mapping.log_odds import RenderConfig, accumulate, place, trinary
from behaviours.nav.mapping.scan import Scan
from hal.occupancy_map import OccupancyMap

FloatArray = npt.NDArray[np.float64]


class GrowingGrid:
    """Log odds over a rectangle that grows as the robot sees more."""

    def __init__(self, config: RenderConfig | None = None, block_m: float = 8.0) -> None:
        self.config = config or RenderConfig()
        self.block_m = block_m
        self.x0 = 0.0
        self.y0 = 0.0
        self.logodds = np.zeros((0, 0), dtype=np.float32)
        self.seen = np.zeros((0, 0), dtype=np.bool_)
        self.scans_added = 0

    @property
    def rows(self) -> int:
        return int(self.logodds.shape[0])

    @property
    def cols(self) -> int:
        return int(self.logodds.shape[1])

    def add(self, scan: Scan, pose: Pose) -> None:
        """Casts one scan's beams at ``pose`` (the robot's, in the map frame)."""
        sensor, pts = place(scan, pose, self.config)
        every = np.vstack([pts, sensor[None, :]])
        self._cover(float(every[:, 0].min()), float(every[:, 1].min()),
                    float(every[:, 0].max()), float(every[:, 1].max()))
        flat_odds = self.logodds.reshape(-1)
        flat_seen = self.seen.reshape(-1)
        accumulate(flat_odds, flat_seen, sensor, pts, self.x0, self.y0, self.cols,
                   self.config)
        self.scans_added += 1

    def rebuild(self, scans: Sequence[Scan], poses: Sequence[Pose]) -> None:
        """Every scan cast again at its (optimised) pose, on a cleared grid."""
        self.logodds[:] = 0.0
        self.seen[:] = False
        self.scans_added = 0
        for scan, pose in zip(scans, poses, strict=True):
            self.add(scan, pose)

    def occupancy(self) -> OccupancyMap:
        """The trinary map of what has been seen so far."""
        res = self.config.resolution_m
        cells = trinary(self.logodds.reshape(-1), self.seen.reshape(-1), self.config)
        return OccupancyMap(cells.reshape(self.rows, self.cols), res, self.x0, self.y0,
                            "mapping")

    def _cover(self, x_min: float, y_min: float, x_max: float, y_max: float) -> None:
        """Grows the arrays (by whole blocks) until the box plus the margin lies inside."""
        res = self.config.resolution_m
        margin = self.config.margin_m
        block = max(1, round(self.block_m / res))
        if self.rows == 0:
            self.x0 = math.floor((x_min - margin) / (block * res)) * block * res
            self.y0 = math.floor((y_min - margin) / (block * res)) * block * res
            cols = math.ceil((x_max + margin - self.x0) / (block * res)) * block
            rows = math.ceil((y_max + margin - self.y0) / (block * res)) * block
            self.logodds = np.zeros((rows, cols), dtype=np.float32)
            self.seen = np.zeros((rows, cols), dtype=np.bool_)
            return
        left = max(0, math.ceil((self.x0 - (x_min - margin)) / (block * res))) * block
        below = max(0, math.ceil((self.y0 - (y_min - margin)) / (block * res))) * block
        right = max(0, math.ceil((x_max + margin - (self.x0 + self.cols * res))
                                 / (block * res))) * block
        above = max(0, math.ceil((y_max + margin - (self.y0 + self.rows * res))
                                 / (block * res))) * block
        if left == below == right == above == 0:
            return
        pad = ((below, above), (left, right))
        self.logodds = np.pad(self.logodds, pad)
        self.seen = np.pad(self.seen, pad)
        self.x0 -= left * res
        self.y0 -= below * res
