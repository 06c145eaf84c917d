"""The fitting phase (the seed's cases 1-4): fit the scan to the map, else turn and fit again,
after a full turn go to the room's middle and turn again, then give up to ``recovery``.

Case 1 ``fit``: a fresh scan (the robot standing still), its points inside
``cabinet.fit_fov_deg`` added to the local map (kept in the odometry frame, so the views of
every orientation add up), the local map fitted onto the global map anywhere at any heading
(``behaviours.nav.scan_match``: correlative search, ICP, honest about ambiguity). Case 2
``change_orientation``: the desired heading is the current one plus
``cabinet.change_orientation_deg``. Case 3 ``drive``: turn (or drive) there on odometry.
Case 4 ``go_room_middle``: the desired location is the middle of the room, estimated without
a pose as the middle of the extent the local map spans (half way there); the local map starts
again there.
"""

from __future__ import annotations

import asyncio
import math
from typing import TYPE_CHECKING

import numpy as np

from behaviours.nav.icp import transform
from behaviours.profiles.cabinet.states import CabinetTrigger
from behaviours.profiles.cabinet.steps.drive_control import wrap
from behaviours.profiles.cabinet.steps.mission import FloatArray, Mission

if TYPE_CHECKING:
    from behaviours.context import RobotContext

FULL_TURN_RAD = 2 * math.pi - 1e-6
_ON_WALL_M = 0.05
_MIN_CONSTRAINT = 0.15
"""The smaller share of the walls' normals' spread a fit needs (0.5: as many in x as in y)."""
_MAX_LOCAL_POINTS = 1600
ROOM_EXTENT_PCT = (10.0, 90.0)


def _odom_points(mission: Mission, robot_points: FloatArray) -> FloatArray:
    o = mission.odom_pose()
    c, s = math.cos(o.theta_rad), math.sin(o.theta_rad)
    x, y = robot_points[:, 0], robot_points[:, 1]
    return np.column_stack((o.x_m + c * x - s * y, o.y_m + s * x + c * y))


def _robot_points(mission: Mission, odom_points: FloatArray) -> FloatArray:
    o = mission.odom_pose()
    c, s = math.cos(o.theta_rad), math.sin(o.theta_rad)
    dx, dy = odom_points[:, 0] - o.x_m, odom_points[:, 1] - o.y_m
    return np.column_stack((c * dx + s * dy, -s * dx + c * dy))


def in_view(points: FloatArray, fov_deg: float) -> FloatArray:
    """The points within ``fov_deg`` centred ahead (all of them at 360)."""
    if fov_deg >= 360.0:
        return points
    bearing = np.abs(np.arctan2(points[:, 1], points[:, 0]))
    return points[bearing <= math.radians(fov_deg) / 2]


class Fitting:
    """The fitting phase's steps as state tasks."""

    def __init__(self, mission: Mission) -> None:
        self.m = mission

    async def fit(self, ctx: RobotContext) -> None:
        m = self.m
        assert m.site is not None and m.matcher is not None and m.drive is not None
        scan = await m.fresh_scan()
        if scan is None:
            await ctx.trigger(CabinetTrigger.NO_FIT_ANYWHERE, reason="fitting: no LiDAR scan")
            return
        view = in_view(scan.points_xy(), m.config.fit_fov_deg)
        m.local_points.append(_odom_points(m, view))
        covered_deg = min(360.0, m.config.fit_fov_deg + math.degrees(m.turned_rad))
        if covered_deg + 1e-6 < m.config.fit_min_view_deg:
            m.fits += 1
            ctx.emit("fit.tried", attempt=m.fits, accepted=False, score=None, rival_score=None,
                     reason=(f"the local map covers {covered_deg:.0f} deg, fit_min_view_deg is "
                             f"{m.config.fit_min_view_deg:.0f}"), points=int(sum(
                                 p.shape[0] for p in m.local_points)),
                     turned_deg=round(math.degrees(m.turned_rad), 1))
            await self._no_fit(ctx)
            return
        local = np.concatenate(m.local_points)
        if local.shape[0] > _MAX_LOCAL_POINTS:
            local = local[np.linspace(0, local.shape[0] - 1, _MAX_LOCAL_POINTS).astype(np.intp)]
        points = _robot_points(m, local)
        walls = m.site.site_map.wall_array()
        area = (float(walls[:, [0, 2]].min()), float(walls[:, [1, 3]].min()),
                float(walls[:, [0, 2]].max()), float(walls[:, [1, 3]].max()))
        # A global fit takes 0.15-1 s of CPU: in a worker thread (numpy releases the GIL for
        # most of it), so the loop keeps the heartbeat, the LiDAR and the watchdog running.
        fit = await asyncio.to_thread(m.matcher.fit_global, points, area)
        m.fits += 1
        m.best_score = max(m.best_score, fit.score)
        x, y, theta = fit.pose
        accepted, reason = fit.accepted, fit.reason
        if accepted:
            reason = self._implausible(points, fit.pose)
            accepted = not reason
        ctx.emit("fit.tried", attempt=m.fits, accepted=accepted, score=round(fit.score, 3),
                 rival_score=round(fit.rival_score, 3), reason=reason,
                 points=int(points.shape[0]), turned_deg=round(math.degrees(m.turned_rad), 1),
                 est_x_m=round(x, 3) if math.isfinite(x) else None,
                 est_y_m=round(y, 3) if math.isfinite(y) else None,
                 est_heading_deg=round(math.degrees(theta), 2) if math.isfinite(theta)
                 else None)
        if accepted:
            m.relocalise(x, y, theta)
            m.drive.pose = m.map_pose
            m.local_points.clear()
            ctx.emit("fit.found", est_x_m=round(x, 4), est_y_m=round(y, 4),
                     est_heading_deg=round(math.degrees(theta), 2), score=round(fit.score, 3),
                     rival_score=round(fit.rival_score, 3), attempts=m.fits)
            await ctx.trigger(CabinetTrigger.FITTED)
            return
        await self._no_fit(ctx)

    async def _no_fit(self, ctx: RobotContext) -> None:
        """Turn on (case 2), or after a full turn the room's middle (case 4), or give up."""
        m = self.m
        if m.turned_rad < FULL_TURN_RAD:
            await ctx.trigger(CabinetTrigger.NO_FIT)
        elif not m.room_middle_tried:
            await ctx.trigger(CabinetTrigger.FULL_TURN)
        else:
            await ctx.trigger(CabinetTrigger.NO_FIT_ANYWHERE, reason=(
                f"fitting: no fit after a full turn here and in the room's middle (best score "
                f"{m.best_score:.2f}, fit_min_score {m.config.fit_min_score:.2f})"))

    def _implausible(self, points: FloatArray, pose: tuple[float, float, float]) -> str:
        """Why a fit the matcher accepts cannot be the robot's pose (empty: it can): outside
        every room or inside a wall, or a local map that pins the pose in one direction only
        (a stretch of straight wall: the robot could be anywhere along it)."""
        m = self.m
        assert m.site is not None and m.matcher is not None
        x, y, _theta = pose
        if m.site.site_map.room_at(x, y) is None:
            return f"the pose ({x:.2f}, {y:.2f}) is in no room of the map"
        if m.site.field.at(x, y) < m.config.robot_radius_m * 0.75:
            return f"the pose ({x:.2f}, {y:.2f}) is inside a wall"
        dist, _closest, normal = m.matcher.walls.nearest(transform(points, pose))
        on = normal[dist < _ON_WALL_M]
        if on.shape[0] < 10:
            return "too few scan points on the walls"
        eig = np.linalg.eigvalsh(on.T @ on / on.shape[0])
        if float(eig[0]) < _MIN_CONSTRAINT:
            return (f"degenerate: the local map pins the pose across {eig[1]:.2f} but along "
                    f"{eig[0]:.2f} (below {_MIN_CONSTRAINT}): walls of one direction only")
        return ""

    async def change_orientation(self, ctx: RobotContext) -> None:
        m = self.m
        step = m.config.change_orientation_rad
        m.desired_heading_rad = wrap(m.odom_pose().theta_rad + step)
        m.desired_point = None
        m.turned_rad += step
        ctx.emit("fit.change_orientation", turn_deg=round(math.degrees(step), 1),
                 turned_deg=round(math.degrees(m.turned_rad), 1))
        await ctx.trigger(CabinetTrigger.ORIENTATION_SET)

    async def go_room_middle(self, ctx: RobotContext) -> None:
        m = self.m
        local = np.concatenate(m.local_points) if m.local_points else np.zeros((0, 2))
        o = m.odom_pose()
        if local.shape[0]:
            # The room's middle, as far as it can be told without a pose: the middle of the
            # extent the local map spans (its 10th to 90th percentile each way: a few far
            # points through a door do not count). The points' median, tried first, stays
            # with whatever is nearest (furniture round the robot, a wall close by).
            lo = np.percentile(local, ROOM_EXTENT_PCT[0], axis=0)
            hi = np.percentile(local, ROOM_EXTENT_PCT[1], axis=0)
            mx, my = float(lo[0] + hi[0]) / 2, float(lo[1] + hi[1]) / 2
            # Half way there: never into the furniture it sees.
            m.desired_point = ((o.x_m + mx) / 2, (o.y_m + my) / 2)
        else:
            m.desired_point = (o.x_m, o.y_m)
        m.room_middle_tried = True
        m.turned_rad = 0.0
        m.local_points.clear()
        ctx.emit("fit.go_room_middle", odom_x_m=round(m.desired_point[0], 3),
                 odom_y_m=round(m.desired_point[1], 3))
        await ctx.trigger(CabinetTrigger.ROOM_MIDDLE_SET)

    async def drive(self, ctx: RobotContext) -> None:
        m = self.m
        assert m.drive is not None
        if m.desired_point is not None:
            x, y = m.desired_point
            await m.drive.drive_to(x, y, stall_s=m.config.blocked_s)
            m.desired_point = None
        else:
            await m.drive.turn_to(m.desired_heading_rad)
        await ctx.trigger(CabinetTrigger.DRIVEN)
