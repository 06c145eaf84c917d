"""The cabinet action phase (the seed leaves it empty; ``docs/cabinet.md`` defines it): face the
cabinet's front, approach to the standoff the LiDAR measures, perform the task's action,
report ``cabinet.arrived`` with the pose error, back off to the cabinet's node, next task.

Actions: ``open_latch`` (the servo to ``LATCH_OPEN_DEG``, held, and back), ``announce`` (an
event a speaker or the fleet takes up), ``snapshot`` (the scan as seen from the standoff, in
an event, for the report), ``none``.
"""

from __future__ import annotations

import asyncio
import math
from typing import TYPE_CHECKING

import numpy as np

from behaviours.profiles.cabinet.states import CabinetTrigger
from behaviours.profiles.cabinet.steps.drive_control import wrap
from behaviours.profiles.cabinet.steps.mission import Mission

if TYPE_CHECKING:
    from behaviours.context import RobotContext

AHEAD_RAD = math.radians(4.0)
"""The beams whose median range is the distance to the cabinet's front."""
LATCH_OPEN_DEG = 90
LATCH_CLOSED_DEG = 0
LATCH_HOLD_S = 2.0
_SNAPSHOT_POINTS = 90


class CabinetAction:
    """The cabinet action phase's steps as state tasks."""

    def __init__(self, mission: Mission) -> None:
        self.m = mission
        self.measured_m: float | None = None

    def _cabinet(self) -> tuple[str, float, float, float, float]:
        """The task's cabinet: name, the planned standoff pose (x, y, heading), standoff."""
        m = self.m
        assert m.site is not None and m.current is not None
        cabinet = m.site.site_map.cabinet(m.current.cabinet)
        standoff = m.standoff_m(m.current)
        x, y = cabinet.front_point(standoff)
        return cabinet.name, x, y, cabinet.facing_rad, standoff

    def ahead_m(self) -> float | None:
        """The LiDAR's range straight ahead (median of the beams within 4 degrees)."""
        scan = self.m.scan
        if scan is None:
            return None
        near = (np.abs(scan.angles_rad) <= AHEAD_RAD) & scan.valid
        if not np.any(near):
            return None
        return float(np.median(scan.ranges_m[near]))

    async def face_front(self, ctx: RobotContext) -> None:
        m = self.m
        assert m.drive is not None
        _name, _x, _y, heading, _standoff = self._cabinet()
        await m.drive.turn_to(heading)
        await ctx.trigger(CabinetTrigger.FACED)

    async def approach(self, ctx: RobotContext) -> None:
        m = self.m
        assert m.drive is not None
        _name, _x, _y, _heading, standoff = self._cabinet()

        def gap() -> float | None:
            ahead = self.ahead_m()
            return None if ahead is None else ahead - standoff

        await m.drive.drive_straight(gap, timeout_s=20.0)
        await m.fresh_scan(1.0)
        self.measured_m = self.ahead_m()
        await ctx.trigger(CabinetTrigger.AT_STANDOFF)

    async def act(self, ctx: RobotContext) -> None:
        m = self.m
        assert m.current is not None
        action = m.current.action
        name = m.current.cabinet
        if action == "open_latch":
            servo = ctx.devices.servo
            if servo is not None:
                await servo.set_angle(LATCH_OPEN_DEG)
                await asyncio.sleep(LATCH_HOLD_S)
                await servo.set_angle(LATCH_CLOSED_DEG)
            ctx.emit("cabinet.latch", cabinet=name, servo=servo is not None,
                     open_deg=LATCH_OPEN_DEG, held_s=LATCH_HOLD_S)
        elif action == "announce":
            ctx.emit("cabinet.announce", cabinet=name, text=f"cabinet {name}: robot here")
        elif action == "snapshot":
            scan = m.scan
            pts = scan.points_xy() if scan is not None else np.zeros((0, 2))
            step = max(1, pts.shape[0] // _SNAPSHOT_POINTS)
            ctx.emit("cabinet.snapshot", cabinet=name, points=int(pts.shape[0]),
                     xy=[[round(float(x), 3), round(float(y), 3)] for x, y in pts[::step]])
        await ctx.trigger(CabinetTrigger.ACTED)

    async def report(self, ctx: RobotContext) -> None:
        m = self.m
        assert m.current is not None
        name, x, y, heading, standoff = self._cabinet()
        p = m.map_pose()
        ctx.emit("cabinet.arrived", cabinet=name, action=m.current.action,
                 plan_x_m=round(x, 4), plan_y_m=round(y, 4),
                 plan_heading_deg=round(math.degrees(heading), 2),
                 est_x_m=round(p.x_m, 4), est_y_m=round(p.y_m, 4),
                 est_heading_deg=round(math.degrees(p.theta_rad), 2),
                 est_error_m=round(math.hypot(p.x_m - x, p.y_m - y), 4),
                 est_heading_error_deg=round(math.degrees(wrap(p.theta_rad - heading)), 2),
                 standoff_m=standoff,
                 measured_standoff_m=None if self.measured_m is None
                 else round(self.measured_m, 4))
        await ctx.trigger(CabinetTrigger.REPORTED)

    async def back_off(self, ctx: RobotContext) -> None:
        m = self.m
        assert m.drive is not None and m.site is not None and m.current is not None
        cabinet = m.site.site_map.cabinet(m.current.cabinet)
        cx, cy = cabinet.position
        ux, uy = math.cos(cabinet.front_rad), math.sin(cabinet.front_rad)
        node_standoff = m.config.standoff_m

        def gap() -> float:
            p = m.map_pose()  # out from the front along its normal; ahead is towards it
            return ((p.x_m - cx) * ux + (p.y_m - cy) * uy) - node_standoff

        await m.drive.drive_straight(gap, timeout_s=20.0)
        m.done.append(cabinet.name)
        m.last_node = m.site.graph.cabinet_node(cabinet.name)
        m.current = None
        m.path, m.path_pos = [], 0
        await ctx.trigger(CabinetTrigger.NEXT_TASK)
