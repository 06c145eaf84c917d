"""Mapping live, on the event loop: LiDAR scans and wheel odometry into the mapping core.

Each LiDAR scan arrives with the odometry pose of that moment. A scan is used only when the
robot stood still through it (odometry moved less than ``still_m`` / ``still_rad`` over this
scan and the one before): the LD19 takes its 450 beams over a tenth of a second, and a scan
taken while turning at 0.5 rad/s is smeared by 3 degrees, more than the matcher's accuracy.
So the robot maps stop-and-go: the exploring driver stops every ``key_distance_m``; a
technician driving with ``robotctl drive`` pauses the same way (a scan is taken each time the
robot stands, once it moved far enough for a key scan).

A still scan that odometry says is far enough from the last key scan becomes a key scan: the
``Mapper`` fits it (50-130 ms, a loop-closure try up to a second and a pose-graph solve) and
the growing grid casts it in. That work runs in a one-thread executor, not on the loop: the
matcher and the solver are NumPy, OpenCV and SciPy calls that cannot be cut into awaitable
pieces, and they release the GIL while they work, so the loop keeps its 10 ms ticks (the
motor board's heartbeat, the drive's control steps) while a key scan is matched. One key scan
at a time: a still scan that comes while the last one is being matched waits for the next.
"""

from __future__ import annotations

import asyncio
import math
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np
import structlog

from behaviours.nav.icp import Pose
from behaviours.nav.mapping.growing_grid import GrowingGrid
from behaviours.nav.mapping.log_odds import RenderConfig, render
from behaviours.nav.mapping.mapper import Mapper, MappingConfig
from behaviours.nav.mapping.scan import Scan, between, compose
from hal.occupancy_map import OCCUPIED, OccupancyMap
from hal.readings import LidarScan
from hal.telemetry import NULL_TELEMETRY, Telemetry

log = structlog.get_logger(__name__)

Emit = Callable[..., None]
LIVE_GRID_LOGODDS = {"free_logodds": -1.2, "hit_logodds": 2.0}
"""The growing grid's updates: one key scan's beam makes a cell free and one return makes it
occupied (a grazing beam through a wall seen once leaves it occupied: 2.0 - 1.2 > 0.62, the
log odds of 0.65). The explorer plans on it as the robot goes; the saved map is rendered with
``render``'s own, more cautious, updates from every key scan (a cell needs three beams)."""


def _no_event(_kind: str, **_fields: Any) -> None:
    """Where events go when nobody listens."""


def mapping_scan(scan: LidarScan, odom: Pose) -> Scan:
    """A driver's scan (robot frame, NaN for no return) as the mapping core's ``Scan``."""
    angles = np.asarray(scan.angles_rad, dtype=np.float64)
    step = float(np.mean(np.diff(angles))) if angles.size > 1 else 0.0
    return Scan(scan.t_s, np.asarray(scan.ranges_m, dtype=np.float64),
                float(angles[0]) if angles.size else 0.0, step, scan.max_range_m, odom,
                beam_angles_rad=angles)


class LiveMapping:
    """The mapping core fed from live scans; ``pose()``, ``occupancy()``, ``save()``.

    Args:
        odometry: the wheel odometry pose now (any frame: only its steps are used).
        start: the map-frame pose the robot starts at (the map's frame is where it started).
        emit: events (``mapping.key_scan``, ``mapping.loop_closed``, ``mapping.saved``).
    """

    def __init__(self, odometry: Callable[[], Pose], *, config: MappingConfig | None = None,
                 start: Pose = (0.0, 0.0, 0.0), still_m: float = 0.005,
                 still_rad: float = math.radians(0.3), emit: Emit | None = None,
                 telemetry: Telemetry = NULL_TELEMETRY) -> None:
        self.mapper = Mapper(config)
        self.config = self.mapper.config
        self.render_config = RenderConfig(resolution_m=self.config.resolution_m)
        self.grid = GrowingGrid(RenderConfig(resolution_m=self.config.resolution_m,
                                             **LIVE_GRID_LOGODDS))
        self.odometry = odometry
        self.start = start
        self.still_m = still_m
        self.still_rad = still_rad
        self.emit: Emit = emit if emit is not None else _no_event
        self.telemetry = telemetry
        self._odom0: Pose | None = None
        self._previous: Pose | None = None
        self._still_before = False
        self._job: asyncio.Future[None] | None = None
        self._executor: ThreadPoolExecutor | None = None
        self._loops_drawn = 0
        self.scans_seen = 0
        self.still_scans = 0
        self.last_still_s = -math.inf
        self.key_work_s: list[float] = []
        self._settled = asyncio.Event()

    # -- scans in -----------------------------------------------------------------------------
    def map_odom(self) -> Pose:
        """The odometry now, in the map's frame (the start pose composed with the steps)."""
        odom = self.odometry()
        if self._odom0 is None:
            self._odom0 = odom
        return compose(self.start, between(self._odom0, odom))

    def on_scan(self, scan: LidarScan) -> None:
        """Called with each LiDAR scan (on the loop): a key scan when it is one."""
        self.scans_seen += 1
        odom = self.map_odom()
        if self.telemetry.enabled:  # the live view: the scan where the mapping puts it
            self.telemetry.scan("scan", scan)
            self.telemetry.pose("pose", self.pose(), child_frame="base_link")
        previous, self._previous = self._previous, odom
        if previous is None:
            return
        step = between(previous, odom)
        still_now = math.hypot(step[0], step[1]) < self.still_m \
            and abs(step[2]) < self.still_rad
        still, self._still_before = still_now and self._still_before, still_now
        if not still:
            return
        self.still_scans += 1
        if self._job is not None:
            return  # the last key scan is still being matched: the next still scan will do
        keys = self.mapper.key_scans
        if keys:
            moved = between(keys[-1].odom, odom)
            if math.hypot(moved[0], moved[1]) < self.config.key_distance_m \
                    and abs(moved[2]) < self.config.key_angle_rad:
                self._mark_settled(scan.t_s)
                return
        converted = mapping_scan(scan, odom)
        key = len(keys)
        self.emit("mapping.key_scan", key=key, odom_x_m=round(odom[0], 4),
                  odom_y_m=round(odom[1], 4), odom_heading_deg=round(math.degrees(odom[2]), 3))
        self._job = asyncio.ensure_future(self._add_key(converted, scan.t_s))

    async def _add_key(self, scan: Scan, t_s: float) -> None:
        loop = asyncio.get_running_loop()
        try:
            await loop.run_in_executor(self._pool(), self._key_work, scan)
        except Exception:  # a bug in one fit must not end mapping: the scan is dropped
            log.exception("mapping.key_failed", t_s=t_s)
        finally:
            self._job = None
        loops = self.mapper.graph.loop_closures()
        if loops > self._loops_drawn:
            self.emit("mapping.loop_closed", key_scans=len(self.mapper.key_scans),
                      loops_closed=loops)
        if self.telemetry.enabled:  # the growing map's walls
            grid = self.grid
            self.telemetry.grid("map", grid.occupancy().cells == OCCUPIED,
                                self.config.resolution_m, (grid.x0, grid.y0))
        self._mark_settled(t_s)

    def _key_work(self, scan: Scan) -> None:
        """In the executor: the fit (and any loop closure), then the scan into the grid."""
        started = time.perf_counter()
        self.mapper.add(scan)
        self.grid.add(scan, self.mapper.graph.poses[-1])
        self.key_work_s.append(time.perf_counter() - started)

    def _mark_settled(self, t_s: float) -> None:
        self.last_still_s = t_s
        self._settled.set()

    def _pool(self) -> ThreadPoolExecutor:
        if self._executor is None:
            self._executor = ThreadPoolExecutor(max_workers=1, thread_name_prefix="mapping")
        return self._executor

    # -- what it knows --------------------------------------------------------------------------
    async def settle(self, after_s: float, timeout_s: float = 3.0) -> bool:
        """Waits until a still scan that began after ``after_s`` (loop time) was used, and its
        key scan (if it was one) is in the map; False after ``timeout_s``."""
        loop = asyncio.get_running_loop()
        deadline = loop.time() + timeout_s
        while self.last_still_s <= after_s or self._job is not None:
            left = deadline - loop.time()
            if left <= 0:
                return False
            self._settled.clear()
            try:
                await asyncio.wait_for(self._settled.wait(), left)
            except TimeoutError:
                return False
        return True

    def pose(self) -> Pose:
        """The robot's pose in the map: its last key scan's estimate plus odometry since."""
        keys = self.mapper.key_scans
        odom = self.map_odom()
        if not keys:
            return odom
        k = len(self.mapper.graph.poses) - 1
        return compose(self.mapper.graph.poses[k], between(keys[k].odom, odom))

    async def occupancy(self) -> OccupancyMap:
        """The map so far; after a loop closure the grid is cast again from the optimised
        poses first (in the executor)."""
        loops = self.mapper.graph.loop_closures()
        if loops > self._loops_drawn and self.mapper.key_scans:
            self._loops_drawn = loops
            await asyncio.get_running_loop().run_in_executor(
                self._pool(), self._rebuild)
        return self.grid.occupancy()

    def _rebuild(self) -> None:
        self.grid.rebuild(self.mapper.key_scans, list(self.mapper.graph.poses))

    async def final_map(self) -> tuple[OccupancyMap, list[Pose]]:
        """The graph solved once more and the map rendered from the optimised key poses (what
        ``save`` writes)."""
        while self._job is not None:
            await asyncio.wait({self._job})

        def work() -> tuple[OccupancyMap, list[Pose]]:
            if self.mapper.graph.edges:
                self.mapper.graph.optimise()
            poses = list(self.mapper.graph.poses)
            return render(self.mapper.key_scans, poses, self.render_config), poses

        return await asyncio.get_running_loop().run_in_executor(self._pool(), work)

    def status(self) -> dict[str, Any]:
        """For ``robotctl status``: key scans, loops closed, the map's size."""
        grid = self.grid
        res = self.config.resolution_m
        x, y, theta = self.pose()
        return {"key_scans": len(self.mapper.key_scans),
                "loops_closed": self.mapper.graph.loop_closures(),
                "loops_tried": self.mapper.loops_tried,
                "matched": self.mapper.accepted, "on_odometry": self.mapper.refused,
                "map_cells": [grid.cols, grid.rows],
                "map_m": [round(grid.cols * res, 2), round(grid.rows * res, 2)],
                "scans_seen": self.scans_seen, "still_scans": self.still_scans,
                "busy": self._job is not None,
                "pose": [round(x, 3), round(y, 3), round(math.degrees(theta), 2)]}

    def close(self) -> None:
        if self._executor is not None:
            self._executor.shutdown(wait=False, cancel_futures=True)
            self._executor = None
