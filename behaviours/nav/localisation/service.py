"""The localisation service: scans into the filter, the fused pose out at ``publish_hz``.

Each scan is handed to the ``Localiser`` with the odometry pose of that moment (the update
runs in the LiDAR's callback: a few milliseconds, vectorised). A timer publishes the fused pose
(correction composed with live odometry) at ``localisation.publish_hz`` whatever the LiDAR
does, so the pose rate (seed property 15: >= 10 Hz) does not hang on scans; while the LiDAR
is stale the published status says ``odometry_only``, then ``lidar_lost``.
"""

from __future__ import annotations

import asyncio
import math
from collections.abc import Callable
from typing import Any

import structlog

from behaviours.motion.odometry import Odometry
from behaviours.nav.localisation.filter import FloatArray, LocalisedPose, Localiser, OdomPose
from behaviours.nav.localisation.people import PeopleTracker, Person
from hal.devices import Lidar
from hal.latest import LatestValue
from hal.readings import LidarScan

log = structlog.get_logger(__name__)


def odometry_source(odometry: Odometry) -> Callable[[], OdomPose]:
    """The service's odometry callable over ``behaviours.motion``'s wheel odometry."""

    def pose() -> OdomPose:
        p = odometry.pose()
        return (p.x_m, p.y_m, p.theta_rad)

    return pose


def start_filter(localiser: Localiser, stored: OdomPose | None = None) -> str:
    """Place the particles as ``localisation.initial_pose`` says; returns where from."""
    c = localiser.config
    if c.initial_pose == "global":
        localiser.start_global()
        return "global"
    if c.initial_pose == "store" and stored is not None:
        localiser.start_at(*stored)
        return "store"
    localiser.start_at(c.initial_x_m, c.initial_y_m, c.initial_heading_rad)
    return "config"


class LocalisationService:
    """Runs a ``Localiser`` on a LiDAR and an odometry source; publishes ``poses``.

    Args:
        localiser: the filter, already started (``start_filter``).
        lidar: the LiDAR device (scans in the robot's frame).
        odometry: returns the odometry pose (x_m, y_m, theta_rad) now.
        people: optional tracker fed every scan with the fused pose; ``people_out`` gets its
            list of people.
    """

    name = "localisation"
    critical = False
    depends_on: tuple[str, ...] = ()

    def __init__(self, localiser: Localiser, lidar: Lidar, odometry: Callable[[], OdomPose],
                 *, people: PeopleTracker | None = None) -> None:
        self.localiser = localiser
        self.lidar = lidar
        self.odometry = odometry
        self.people = people
        self.poses: LatestValue[LocalisedPose] = LatestValue()
        self.people_out: LatestValue[list[Person]] = LatestValue()

    async def run(self, ready: Callable[[], None]) -> None:
        loop = asyncio.get_running_loop()
        stop_listening = self.lidar.listen(self._on_scan)
        ready()
        period_s = 1.0 / self.localiser.config.publish_hz
        next_s = loop.time()
        try:
            while True:
                now_s = loop.time()
                if self.lidar.stale:
                    self.localiser.lidar_stale(now_s)
                self.poses.publish(self.localiser.pose(self.odometry(), now_s))
                # Deadlines on a fixed grid: a late tick does not push the next ones back.
                next_s += period_s
                if next_s < now_s:
                    next_s = now_s + period_s
                await asyncio.sleep(next_s - loop.time())
        finally:
            stop_listening()

    def _on_scan(self, scan: LidarScan) -> None:
        # The LiDAR's driver calls this within the loop step that parsed the scan's bytes; the
        # filter's update (up to ~15 ms of CPU on a PC, x8 on a Pi 4), its resampling and the
        # people tracker each get a step of their own, queued in order, with the odometry of
        # the scan's time.
        loop = asyncio.get_running_loop()
        loop.call_soon(self._update, scan, self.odometry(), loop.time())

    def _update(self, scan: LidarScan, odom: OdomPose, now_s: float) -> None:
        # counts and skips a malformed scan; the resampling is the next step's
        self.localiser.on_scan(odom, scan, now_s, defer_resample=True)
        loop = asyncio.get_running_loop()
        loop.call_soon(self.localiser.finish_update)
        if self.people is not None:
            loop.call_soon(self._track_people, scan, self.localiser.pose_array(odom), now_s)

    def _track_people(self, scan: LidarScan, pose: FloatArray, now_s: float) -> None:
        assert self.people is not None
        self.people_out.publish(self.people.update(scan, pose, now_s))

    def status(self) -> dict[str, Any]:
        """For ``robotctl status``/``sensors``: the pose, its spread and the filter's figures."""
        pose = self.poses.latest()
        loc = self.localiser
        out: dict[str, Any] = {"status": loc.status, "scans": loc.scans,
                               "updates": loc.updates, "particles": len(loc.particles),
                               "rejected_scans": loc.rejected,
                               "divergences": loc.divergences}
        if pose is not None:
            out["pose"] = pose.as_dict()
        if self.people is not None:
            out["people"] = len(self.people_out.latest() or [])
        est = loc.estimate
        if est is not None and math.isfinite(est.spread_m):
            out["spread_m"] = round(est.spread_m, 4)
        return out
