"""Going to (x, y) on the map as one awaitable: the navigation stack's glue for profiles.

``NavStack`` builds, from the settings, what every navigating profile needs: the map
(``map`` section), the planner, the localiser and its service (a pose at ``publish_hz``), the
people tracker, and a ``PathFollower`` whose ``WaypointDrive`` runs on the localised pose
(through the obstacle guard when the robot has a front sensor). ``NavStack.go_to(x, y)``
returns a ``NavOutcome``: reached, or why not: ``no_path``, ``no_progress``, ``diverged``
(localisation lost), ``lidar_lost``. It never raises those; the motors are stopped before it
returns a failure. Scan points the map does not explain (seen while localised) are handed to
the follower as obstacles, so an unmapped box or a walker on the path makes it replan.

Zones (``zones.py``: Nav2's keep-out and speed masks, ``map.keepout_file``/``speed_file``) are
kept out of by the planner and slow the drive while it goes. A filter that diverges while the
robot drives is relocalised over the whole map (``relocalise.py``, ``localisation.relocalise``)
and the goal planned again from where the robot turns out to be; an operator's pose
(``set_pose``, ``robotctl pose set``) re-seeds the filter and replans the same way.
"""

from __future__ import annotations

import asyncio
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import structlog

from behaviours.motion.config import DriveTuning
from behaviours.motion.obstacle_guard import ObstacleGuard
from behaviours.motion.odometry import Odometry, OdometryPose
from behaviours.motion.waypoint_drive import WaypointDrive
from behaviours.nav.config import MapConfig, PlannerConfig, ZoneConfig
from behaviours.nav.grid import Grid
from behaviours.nav.localisation.config import LocalisationConfig, PeopleConfig
from behaviours.nav.localisation.filter import (
    DIVERGED,
    LIDAR_LOST,
    LOCALISED,
    UNCERTAIN,
    LocalisedPose,
    Localiser,
    OdomPose,
)
from behaviours.nav.localisation.likelihood_field import DistanceGrid
from behaviours.nav.localisation.motion_model import compose, inverse
from behaviours.nav.localisation.people import PeopleTracker, unexplained_points
from behaviours.nav.localisation.service import LocalisationService, odometry_source, start_filter
from behaviours.nav.map_file import WALLS, load_grid
from behaviours.nav.path_follower import NoProgress, PathFollower
from behaviours.nav.planner import NoPath, Planner
from behaviours.nav.relocalise import Relocaliser
from behaviours.nav.zones import NO_LIMIT, SPEED_MARGIN, SpeedLimit, Zones
from behaviours.profile import SiteFacts
from hal.devices import Lidar, Motors, RangeSensor
from hal.readings import LidarScan
from hal.settings import SettingsView
from hal.tasks import cancel_and_wait
from hal.telemetry import NULL_TELEMETRY, Telemetry

log = structlog.get_logger(__name__)

FAILURES = ("no_path", "no_progress", "diverged", "lidar_lost")
_WATCH_S = 0.1
_LOCALISE_WAIT_S = 10.0
"""How long a goal waits, standing, for the first localised pose."""
_OBSTACLE_RANGE_M = 3.0
_REPLAN = "replan"


def _no_event(_kind: str, **_fields: Any) -> None:
    """Where events go when the stack is given no ``emit``."""


@dataclass(frozen=True, slots=True)
class NavOutcome:
    """How a ``go_to`` ended: ``reason`` is ``reached`` or one of ``FAILURES``."""

    reason: str
    goal: tuple[float, float]
    x_m: float
    y_m: float
    remaining_m: float
    replans: int
    duration_s: float
    detail: str = ""

    @property
    def reached(self) -> bool:
        return self.reason == "reached"


class NavStack:
    """Map, planner, localisation and follower of one robot (one per profile instance)."""

    def __init__(self, settings: SettingsView, motors: Motors, lidar: Lidar,
                 odometry: Odometry, *, front_range: RangeSensor | None = None,
                 stored_pose: tuple[float, float, float] | None = None,
                 emit: Callable[..., None] | None = None, grid: Grid | None = None,
                 telemetry: Telemetry = NULL_TELEMETRY) -> None:
        self.settings = settings
        self.lidar = lidar
        self.odometry = odometry
        map_config = MapConfig.from_settings(settings)
        if grid is None:  # a profile with its own map format (cabinet) gives its grid
            grid = load_grid(map_config)
        self.map_name = Path(map_config.file).stem
        """The map's name as a site knows it (its file's stem; ``walls``: the world's)."""
        self.zones = Zones.from_config(ZoneConfig.from_settings(settings),
                                       None if map_config.file == WALLS else map_config.file)
        self.planner_config = PlannerConfig.from_settings(settings)
        self.planner = Planner(grid, self.planner_config, keepout=self.zones.keepout_for(grid))
        self.distance = DistanceGrid.from_field(self.planner.field)
        self.localiser = Localiser(self.distance, LocalisationConfig.from_settings(settings))
        self.started_from = start_filter(self.localiser, stored_pose)
        self.people_config = PeopleConfig.from_settings(settings)
        self.people = PeopleTracker(self.people_config, self.distance)
        self._odom = odometry_source(odometry)
        est = self.localiser.estimate
        if est is not None:  # the start pose is the pose until the first filter update
            start = np.array([est.x_m, est.y_m, est.theta_rad])
            self.localiser.correction = compose(start, inverse(np.asarray(self._odom())))
        self.service = LocalisationService(self.localiser, lidar, self._odom, people=self.people)
        self.motors: Motors = motors
        if front_range is not None:
            self.motors = ObstacleGuard(motors, front_range, settings, emit)
        self.drive = WaypointDrive(self.motors, odometry, settings, pose_source=self.pose)
        self.follower = PathFollower(self.planner, self.drive, self.planner_config)
        self.emit: Callable[..., None] = emit if emit is not None else _no_event
        self.relocaliser = Relocaliser(self.localiser, lidar, self.motors, self._odom, settings)
        self.relocalisations = 0
        self.pose_epoch = 0
        """Counts operator poses (``set_pose``): a drive under way replans from the new one."""
        self.speed_limit: SpeedLimit = NO_LIMIT
        self._encoder_scale = 1.0
        if self.zones.active:
            self.emit("nav.zones", **self.zones.describe(),
                      speed_top_mps=DriveTuning.from_settings(settings).cruise_mps)
        self.poses_published = 0
        self.service.poses.listen(self._count)
        self._stop_scans: Callable[[], None] | None = None
        self.telemetry = telemetry
        self._shown_scan_s = -1.0
        if telemetry.enabled:  # the live view: nothing is even listened to while it is off
            self.service.poses.listen(self._show)

    def _count(self, _pose: object) -> None:
        self.poses_published += 1

    def _show(self, pose: LocalisedPose) -> None:
        """The live view at the pose rate: estimate, the odom frame, the newest scan,
        particles, plan, map and zones (the heavy ones are decimated by the telemetry adapter;
        odometry itself is ``OdometryTracker``'s). No listener on the LiDAR: the device
        outlives a daemon the simulator restarts, the service's poses do not."""
        t = self.telemetry
        scan = self.lidar.latest()
        if scan is not None and scan.t_s != self._shown_scan_s:
            self._shown_scan_s = scan.t_s
            t.scan("scan", scan)
        t.pose("pose", (pose.x_m, pose.y_m, pose.theta_rad), child_frame="base_link")
        t.sample("localisation", status=pose.status, spread_m=round(pose.spread_m, 4),
                 match_fraction=round(pose.match_fraction, 3), particles=pose.particles)
        c = self.localiser.correction  # map <- odom: the odom frame in the map
        t.pose("odom_in_map", (float(c[0]), float(c[1]), float(c[2])), child_frame="odom")
        t.poses("particles", self.localiser.particles.poses)
        plan = self.follower.plan
        t.path("path", plan.points if plan is not None else [])
        grid = self.planner.grid
        t.grid("map", grid.occupied, grid.resolution_m, (grid.origin_x_m, grid.origin_y_m))
        keepout = self.planner.keepout
        if keepout is not None:  # the zones beside the map (decimated as it is)
            t.grid("keepout", keepout.inside, grid.resolution_m,
                   (grid.origin_x_m, grid.origin_y_m))
        if self.zones.speed is not None:
            t.sample("speed_limit", limit_mps=self.speed_limit.limit_mps,
                     value=self.speed_limit.value)

    def encoders_failed(self, failed: bool) -> None:
        """The seed's encoder failure: LiDAR-only localisation and half the speed while the
        encoders are frozen (``True``); back to normal when they return (``False``)."""
        self.localiser.set_lidar_only(failed, self._odom())
        self._encoder_scale = 0.5 if failed else 1.0
        self._apply_speed_scale()

    def _apply_speed_scale(self) -> None:
        """The drive's speed: half while the encoders have failed, and no more than the speed
        zone allows (the lower of the two)."""
        scale = self._encoder_scale
        limit = self.speed_limit.limit_mps
        if limit is not None:
            cruise = DriveTuning.from_settings(self.settings).cruise_mps
            scale = min(scale, limit * SPEED_MARGIN / cruise)
        self.drive.speed_scale = scale

    def limit_speed(self) -> SpeedLimit:
        """The speed mask's limit at the robot and on its path ahead, applied to the drive
        (``nav.speed_limit`` when it changes)."""
        if self.zones.speed is None:
            return NO_LIMIT
        ahead = self.follower.remaining_path()
        if not ahead:
            pose = self.pose()
            ahead = [(pose.x_m, pose.y_m)]
        cruise = DriveTuning.from_settings(self.settings).cruise_mps
        limit = self.zones.limit_along(ahead, cruise)
        if limit != self.speed_limit:
            self.speed_limit = limit
            self._apply_speed_scale()
            self.emit("nav.speed_limit", limit_mps=None if limit.limit_mps is None
                      else round(limit.limit_mps, 4), value=limit.value,
                      limit=None if limit.limit_mps is None else round(limit.limit, 3),
                      est_x_m=round(ahead[0][0], 3), est_y_m=round(ahead[0][1], 3))
        return limit

    def set_pose(self, x_m: float, y_m: float, theta_rad: float,
                 sigma_m: float | None = None, sigma_rad: float | None = None) -> None:
        """An operator's pose (``robotctl pose set``): the filter re-seeded round it, the
        published pose there at once; a drive under way plans again from it."""
        self.localiser.start_at(x_m, y_m, theta_rad, sigma_m, sigma_rad)
        pose = np.array([x_m, y_m, theta_rad], dtype=np.float64)
        self.localiser.correction = compose(pose, inverse(np.asarray(self._odom())))
        self.localiser.mark_uncertain()
        self.pose_epoch += 1
        fields = {"est_x_m": round(x_m, 4), "est_y_m": round(y_m, 4),
                  "est_heading_deg": round(math.degrees(theta_rad), 2),
                  "sigma_m": None if sigma_m is None else round(sigma_m, 4)}
        log.info("nav.pose_set", **fields)
        self.emit("nav.pose_set", **fields)

    async def relocalise(self) -> bool:
        """Find the robot anywhere on the map (``relocalise.py``); True once localised."""
        est = self.localiser.estimate
        self.emit("nav.relocalise", status=self.localiser.status,
                  spread_m=None if est is None else round(min(est.spread_m, 99.0), 4),
                  match_fraction=round(self.localiser.match_fraction, 3))
        config = self.localiser.config
        epoch = self.pose_epoch
        result = await self.relocaliser.run(config.relocalise_limit_s,
                                            lambda: self.pose_epoch != epoch)
        pose = self.pose()
        fields: dict[str, Any] = {
            "ok": result.ok, "searches": result.searches,
            "duration_s": round(result.duration_s, 2),
            "turned_deg": round(math.degrees(result.turned_rad), 1),
            "fit_per_beam": round(result.fit_per_beam, 3) if math.isfinite(
                result.fit_per_beam) else None,
            "est_x_m": round(pose.x_m, 4), "est_y_m": round(pose.y_m, 4),
            "est_heading_deg": round(math.degrees(pose.theta_rad), 2),
            "by": "operator" if self.pose_epoch != epoch else "search"}
        if result.ok:
            self.relocalisations += 1
            log.info("nav.relocalised", **fields)
            self.emit("nav.relocalised", **fields)
        else:
            log.error("nav.relocalise_failed", detail=result.detail, **fields)
            self.emit("nav.relocalise_failed", detail=result.detail, **fields)
        return result.ok

    def pose(self) -> OdometryPose:
        """The fused map pose now (correction x live odometry)."""
        p = self.localiser.pose_array(self._odom())
        return OdometryPose(float(p[0]), float(p[1]), float(p[2]))

    def site_facts(self, job: str | None = None, map_name: str | None = None) -> SiteFacts:
        """The last published map pose (none before the first) on ``map_name`` (default the
        map file's), with ``job``, for the site report (``Profile.site_facts``)."""
        pose = self.service.poses.latest()
        if pose is None:
            return SiteFacts(job=job)
        return SiteFacts(x_m=pose.x_m, y_m=pose.y_m, theta_rad=pose.theta_rad,
                         map_name=map_name or self.map_name, job=job)

    def live_pose(self) -> LocalisedPose:
        """The fused pose as of now (not the last one published)."""
        return self.localiser.pose(self._odom(), asyncio.get_running_loop().time())

    def watch_scans(self) -> Callable[[], None]:
        """Feed unexplained scan points to the follower as obstacles (call once running)."""
        if self._stop_scans is None:
            self._stop_scans = self.lidar.listen(self._on_scan)
        return self._stop_scans

    def _on_scan(self, scan: LidarScan) -> None:
        # In a loop step of its own, after the localisation's update of this scan (queued
        # first: its listener was registered first), with the odometry of the scan's time.
        asyncio.get_running_loop().call_soon(self._see_obstacles, scan, self._odom())

    def _see_obstacles(self, scan: LidarScan, odom: OdomPose) -> None:
        if self.localiser.status != LOCALISED:
            return  # unexplained points of a wrong pose are the map's walls, misplaced
        pose = self.localiser.pose_array(odom)
        pts = unexplained_points(scan, pose, self.distance, self.people_config)
        if pts.shape[0] == 0:
            return
        pts = pts[np.hypot(pts[:, 0], pts[:, 1]) <= _OBSTACLE_RANGE_M]
        c, s = math.cos(pose[2]), math.sin(pose[2])
        mx = pose[0] + c * pts[:, 0] - s * pts[:, 1]
        my = pose[1] + s * pts[:, 0] + c * pts[:, 1]
        res = self.planner.grid.resolution_m
        cells = np.unique(np.column_stack((np.round(mx / res), np.round(my / res))), axis=0)
        self.follower.see_obstacles((float(x * res), float(y * res)) for x, y in cells)

    async def go_to(self, x_m: float, y_m: float) -> NavOutcome:
        """Plan and drive to a map point; the outcome says whether and why not."""
        loop = asyncio.get_running_loop()
        started = loop.time()
        replans = self.follower.replans
        # Not from an uncertain pose: after a global start the first scans must pick the
        # pose out of the map before a path from it means anything.
        while self.localiser.status == UNCERTAIN:  # the filter has no event: polled
            if loop.time() - started >= _LOCALISE_WAIT_S:
                break
            await asyncio.sleep(_WATCH_S)
        if self.localiser.status == UNCERTAIN:
            pose = self.pose()
            detail = f"not localised within {_LOCALISE_WAIT_S:g} s"
            log.info("nav.outcome", reason="not_localised", goal_x_m=x_m, goal_y_m=y_m,
                     detail=detail)
            return NavOutcome("not_localised", (x_m, y_m), pose.x_m, pose.y_m,
                              math.hypot(x_m - pose.x_m, y_m - pose.y_m), 0,
                              loop.time() - started, detail)
        while True:
            reason, detail = await self._drive_to(x_m, y_m)
            if reason == _REPLAN:
                continue
            if reason == "diverged":
                est = self.localiser.estimate
                self.emit("localisation.diverged", spread_m=round(
                    min(est.spread_m if est else 99.0, 99.0), 4),
                    match_fraction=round(self.localiser.match_fraction, 3), detail=detail)
                if self.localiser.config.relocalise == "global":
                    if await self.relocalise():
                        continue
                    detail = "localisation diverged; global relocalisation failed"
            break
        pose = self.pose()
        outcome = NavOutcome(reason, (x_m, y_m), pose.x_m, pose.y_m,
                             math.hypot(x_m - pose.x_m, y_m - pose.y_m),
                             self.follower.replans - replans, loop.time() - started, detail)
        log.info("nav.outcome", reason=reason, goal_x_m=x_m, goal_y_m=y_m,
                 remaining_m=round(outcome.remaining_m, 3), detail=detail)
        return outcome

    async def _drive_to(self, x_m: float, y_m: float) -> tuple[str, str]:
        """One drive at the goal: (reason, detail), ``_REPLAN`` after an operator's pose."""
        task = asyncio.create_task(self.follower.go_to(x_m, y_m))
        epoch = self.pose_epoch
        jumps = self.localiser.jumps
        reason, detail = "reached", ""
        try:
            while True:
                done, _ = await asyncio.wait({task}, timeout=_WATCH_S)
                if self.localiser.jumps != jumps:  # an arrival on a leapt pose is none
                    jump_m, jump_rad = self.localiser.last_jump
                    reason = "diverged"
                    detail = (f"localisation jumped {jump_m:.2f} m, "
                              f"{math.degrees(jump_rad):.0f} deg")
                    break
                if done:
                    break
                if self.pose_epoch != epoch:
                    reason = _REPLAN
                    break
                if self.zones.speed is not None:
                    self.limit_speed()
                status = self.localiser.status
                if status in (DIVERGED, LIDAR_LOST):
                    reason = "diverged" if status == DIVERGED else "lidar_lost"
                    detail = f"localisation {status}"
                    break
            if reason == "reached":
                try:
                    task.result()
                except NoPath as exc:
                    reason, detail = "no_path", str(exc)
                except NoProgress as exc:
                    reason, detail = "no_progress", str(exc)
        finally:
            if not task.done():
                await cancel_and_wait(task)
            if reason != "reached":
                await self.drive.stop()
        return reason, detail

    def status(self) -> dict[str, Any]:
        """For ``robotctl status``/``sensors``: pose, spread, scan rate, the plan."""
        out = self.service.status()
        lidar_status = getattr(self.lidar, "status", None)
        if callable(lidar_status):
            figures = lidar_status()
            if isinstance(figures, dict) and "scan_rate_hz" in figures:
                out["scan_rate_hz"] = figures["scan_rate_hz"]
        plan = self.follower.plan
        if plan is not None:
            out["plan"] = {"waypoints": [[round(x, 3), round(y, 3)] for x, y in plan.points],
                           "length_m": round(plan.length_m, 3),
                           "replans": self.follower.replans}
        out["poses_published"] = self.poses_published
        if self.relocalisations:
            out["relocalisations"] = self.relocalisations
        if self.zones.speed is not None:
            out["speed_limit_mps"] = self.speed_limit.limit_mps
        return out


def stored_pose(values: Mapping[str, Any]) -> tuple[float, float, float] | None:
    """A pose record's values (``x_m``, ``y_m``, ``heading_rad``) as ``NavStack``'s
    ``stored_pose``; None while none has been stored."""
    if values["x_m"] is None:
        return None
    return float(values["x_m"]), float(values["y_m"]), float(values["heading_rad"])


class NavLocalisation:
    """The localisation service of a profile on the navigation stack, with the stack's status
    (pose, spread, scan rate, plan) for ``robotctl status``."""

    name = "localisation"
    critical = False
    depends_on: tuple[str, ...] = ("odometry",)

    def __init__(self, nav: NavStack) -> None:
        self.nav = nav

    async def run(self, ready: Any) -> None:
        await self.nav.service.run(ready)

    def status(self) -> dict[str, Any]:
        return self.nav.status()
