"""The relocate phase (the seed's cases 1-5): A* over the node graph's open links to the task's
cabinet, node after node on the localised pose, breaking a link the robot cannot drive and
resetting the broken links when no path is left.

Case 1 ``create_path`` takes the next task when there is none in hand (``order``: listed, or
the nearest remaining cabinet by path), joins the graph at the nearest node the robot can
reach in a straight line, and plans; no path while links are broken goes to ``reset_links``,
no path with nothing broken fails the task (``on_unreachable``: ``fail`` ends the mission in
``mission.failed`` naming the cabinet, ``skip`` reports it and takes the next one). Case 3
``drive_to_node`` is blocked when the robot makes no progress for ``cabinet.blocked_s`` or
the scan shows something in the corridor ahead for a second. Case 4 ``break_link`` closes
the link both ways (event ``link.closed``); the new path starts from the last node reached.
Case 5 ``reset_links`` opens them all, at most ``cabinet.max_link_resets`` times per task.
"""

from __future__ import annotations

import asyncio
import itertools
import math
from typing import TYPE_CHECKING

import numpy as np

from behaviours.machine_tables import CoreTrigger
from behaviours.nav.localisation.filter import DIVERGED, LIDAR_LOST
from behaviours.profiles.cabinet.node_graph import NoPath, line_clear
from behaviours.profiles.cabinet.states import CabinetTrigger
from behaviours.profiles.cabinet.steps.mission import Mission, show_graph

if TYPE_CHECKING:
    from behaviours.context import RobotContext

_CORRIDOR_AHEAD_M = 1.0
"""How far ahead along the link the scan is watched for something in the way."""
_CORRIDOR_SCANS = 8
"""Consecutive scans (about 1 s) with something in the corridor: blocked."""
_MIN_POINTS = 3
_RESET_PAUSE_S = 5.0


class Relocate:
    """The relocate phase's steps as state tasks."""

    def __init__(self, mission: Mission) -> None:
        self.m = mission
        self._corridor_hits = 0
        self._corridor_scan = -1

    def _start_node(self) -> str | None:
        """Where the path starts: the last node reached, else the nearest node the robot can
        drive to in a straight line from where it is (joining the graph)."""
        m = self.m
        assert m.site is not None
        graph = m.site.graph
        if m.last_node is not None:
            return m.last_node
        p = m.map_pose()
        clearance = m.config.robot_radius_m * 0.75
        for name in sorted(graph.nodes, key=lambda n: math.hypot(
                graph.nodes[n].x_m - p.x_m, graph.nodes[n].y_m - p.y_m)):
            if name not in m.avoid_start and line_clear(
                    (p.x_m, p.y_m), graph.nodes[name].point, m.site.field, clearance):
                return name
        return None

    def _next_task(self) -> bool:
        """Take the next task (in the configured order); False when none is left."""
        m = self.m
        assert m.site is not None and m.tasks is not None
        if not m.remaining:
            return False
        index = 0
        if m.tasks.order == "nearest" and len(m.remaining) > 1:
            start = self._start_node()
            lengths = []
            for task in m.remaining:
                try:
                    path = m.site.graph.create_path(start or "", task.cabinet)
                    lengths.append(_length(m, path))
                except NoPath:
                    lengths.append(math.inf)
            index = int(np.argmin(lengths))
        m.current = m.remaining.pop(index)
        m.site.graph.begin_task()
        m.avoid_start.clear()
        return True

    async def create_path(self, ctx: RobotContext) -> None:
        m = self.m
        assert m.site is not None and m.tasks is not None
        graph = m.site.graph
        while True:
            if m.current is None and not self._next_task():
                m.path, m.path_pos = [], 0
                ctx.emit("mission.done", done=list(m.done), skipped=list(m.skipped))
                await ctx.trigger(CoreTrigger.MISSION_DONE)
                return
            assert m.current is not None
            cabinet = m.current.cabinet
            start = self._start_node()
            try:
                if start is None:
                    raise NoPath("no node of the graph is in a straight line from here",
                                 graph.broken_links())
                path = graph.create_path(start, cabinet)
            except NoPath as exc:
                if graph.broken and graph.may_reset():
                    ctx.emit("path.none", cabinet=cabinet, reason=exc.reason, will_reset=True)
                    await ctx.trigger(CabinetTrigger.NO_PATH_LINKS_BROKEN)
                    return
                reason = (f"cabinet {cabinet}: {exc.reason}" if not graph.broken else
                          f"cabinet {cabinet}: {exc.reason}; the broken links were reset "
                          f"{graph.resets_this_task} time(s) (cabinet.max_link_resets "
                          f"{graph.max_resets})")
                if m.tasks.on_unreachable == "skip":
                    ctx.emit("task.skipped", cabinet=cabinet, reason=reason)
                    m.skipped.append(cabinet)
                    m.current = None
                    continue
                await self._fail(ctx, reason, CabinetTrigger.NO_PATH)
                return
            m.path, m.path_pos = path, 0
            ctx.emit("path.planned", cabinet=cabinet, nodes=path,
                     length_m=round(_length(m, path), 3), broken=len(graph.broken))
            show_graph(ctx.telemetry, m, with_path=True)
            await ctx.trigger(CabinetTrigger.PATH_FOUND)
            return

    async def _fail(self, ctx: RobotContext, reason: str, trigger: str) -> None:
        m = self.m
        if m.drive is not None:
            await m.drive.stop()
        ctx.emit("mission.failed", cabinet=m.current.cabinet if m.current else None,
                 reason=reason)
        await ctx.trigger(trigger, reason=reason)

    async def proceed_path(self, ctx: RobotContext) -> None:
        m = self.m
        if m.path_pos >= len(m.path):
            m.next_node = None
            await ctx.trigger(CabinetTrigger.PATH_DONE)
            return
        m.next_node = m.path[m.path_pos]
        await ctx.trigger(CabinetTrigger.NEXT_NODE)

    async def drive_to_node(self, ctx: RobotContext) -> None:
        m = self.m
        assert m.site is not None and m.drive is not None and m.next_node is not None
        node = m.site.graph.nodes[m.next_node]
        self._corridor_hits = 0
        result = await m.drive.drive_to(node.x_m, node.y_m, stall_s=m.config.blocked_s,
                                        blocked=lambda: self._blocked(node.x_m, node.y_m))
        if result.reached:
            ctx.emit("node.reached", node=node.name, error_m=round(result.remaining_m, 3))
            m.last_node, m.next_node = node.name, None
            m.path_pos += 1
            await ctx.trigger(CabinetTrigger.NODE_REACHED)
            return
        if result.reason.startswith("localisation"):
            ctx.emit("localisation.lost", reason=result.reason)
            m.last_node = m.next_node = None
            m.local_points.clear()
            m.turned_rad, m.room_middle_tried, m.best_score = 0.0, False, 0.0
            m.drive.pose = m.odom_pose
            await ctx.trigger(CabinetTrigger.LOST_POSE)
            return
        m.blocked_reason = result.reason
        ctx.emit("link.blocked", a=m.last_node, b=node.name, reason=result.reason,
                 remaining_m=round(result.remaining_m, 3))
        await ctx.trigger(CabinetTrigger.BLOCKED)

    def _blocked(self, x_m: float, y_m: float) -> str | None:
        """Why the drive must stop (the localisation lost, the corridor seen blocked), or
        None."""
        m = self.m
        assert m.nav is not None
        status = m.nav.localiser.status
        if status in (DIVERGED, LIDAR_LOST):
            return f"localisation {status}"
        scan = m.scan
        if scan is None or m.scans == self._corridor_scan:
            return None
        self._corridor_scan = m.scans
        if self._in_corridor(scan.points_xy(), x_m, y_m):
            self._corridor_hits += 1
        else:
            self._corridor_hits = 0
        if self._corridor_hits >= _CORRIDOR_SCANS:
            return "the scan shows the corridor ahead blocked"
        return None

    def _in_corridor(self, points: np.ndarray, x_m: float, y_m: float) -> bool:
        """Whether the scan has points on the robot's way to (x, y), within the robot's
        width (plus a little) and ``_CORRIDOR_AHEAD_M`` ahead."""
        m = self.m
        p = m.map_pose()
        dx, dy = x_m - p.x_m, y_m - p.y_m
        length = math.hypot(dx, dy)
        if length < 0.05 or points.shape[0] == 0:
            return False
        c, s = math.cos(p.theta_rad), math.sin(p.theta_rad)
        mx = p.x_m + c * points[:, 0] - s * points[:, 1]
        my = p.y_m + s * points[:, 0] + c * points[:, 1]
        ux, uy = dx / length, dy / length
        along = (mx - p.x_m) * ux + (my - p.y_m) * uy
        across = np.abs(-(mx - p.x_m) * uy + (my - p.y_m) * ux)
        reach = min(_CORRIDOR_AHEAD_M, length - 0.05)
        hit = (along > 0.05) & (along < reach) & (across < m.config.robot_radius_m + 0.02)
        return int(np.count_nonzero(hit)) >= _MIN_POINTS

    async def break_link(self, ctx: RobotContext) -> None:
        m = self.m
        assert m.site is not None
        graph = m.site.graph
        a, b = m.last_node, m.next_node or ""
        if a is None:  # blocked on the way onto the graph: join it elsewhere
            m.avoid_start.add(b)
            ctx.emit("link.closed", a=None, b=b, reason=m.blocked_reason, joined=False)
        else:
            graph.break_link(a, b)
            na, nb = graph.nodes[a], graph.nodes[b]
            ctx.emit("link.closed", a=a, b=b, reason=m.blocked_reason,
                     a_xy=[round(na.x_m, 3), round(na.y_m, 3)],
                     b_xy=[round(nb.x_m, 3), round(nb.y_m, 3)],
                     broken=[list(k) for k in graph.broken_links()])
        m.next_node = None
        show_graph(ctx.telemetry, m)
        await ctx.trigger(CabinetTrigger.LINK_BROKEN)

    async def reset_links(self, ctx: RobotContext) -> None:
        m = self.m
        assert m.site is not None
        graph = m.site.graph
        if not graph.may_reset():
            cabinet = m.current.cabinet if m.current else "?"
            await self._fail(ctx, f"cabinet {cabinet}: no path while links are broken, and "
                                  f"the broken links were reset {graph.resets_this_task} "
                                  f"time(s) already (cabinet.max_link_resets "
                                  f"{graph.max_resets})", CabinetTrigger.RESET_LIMIT)
            return
        # A moment for a dynamic obstacle (a person) to move on before the same links again.
        await asyncio.sleep(min(m.config.blocked_s, _RESET_PAUSE_S))
        opened = graph.reset_links()
        ctx.emit("links.reset", opened=opened, resets=graph.resets_this_task,
                 max_resets=graph.max_resets,
                 cabinet=m.current.cabinet if m.current else None)
        show_graph(ctx.telemetry, m)
        await ctx.trigger(CabinetTrigger.LINKS_RESET)


def _length(m: Mission, path: list[str]) -> float:
    assert m.site is not None
    nodes = m.site.graph.nodes
    return sum(math.hypot(nodes[a].x_m - nodes[b].x_m, nodes[a].y_m - nodes[b].y_m)
               for a, b in itertools.pairwise(path))
