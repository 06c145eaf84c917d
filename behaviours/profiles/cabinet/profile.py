"""The ``cabinet`` profile: the seed's phases (init, fitting, relocate) and the cabinet action
phase as step tasks on the navigation stack (``docs/cabinet.md``).

The robot is not told where it starts: the init phase reads its files and builds the map,
the node graph and the drive controller; the fitting phase finds its pose by fitting its scan
to the map; the localisation (MCL) starts from that pose; the relocate phase drives the node
graph to each task's cabinet in turn; the cabinet action phase does the task there. An empty
task list ends the mission in ``idle``; a cabinet no path reaches ends it in
``mission.failed`` (wheels stopped, the cabinet named), unless the task list says ``skip``.
"""

from __future__ import annotations

import asyncio
import math
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, Generic, TypeVar

from behaviours.machine_tables import CoreTrigger
from behaviours.motion.odometry import Odometry
from behaviours.motion.waypoint_drive import OdometryTracker
from behaviours.nav.navigator import NavStack
from behaviours.nav.scan_match import MatchConfig, ScanMatcher
from behaviours.profile import (
    BaseProfile,
    ControlMethod,
    ControlRefused,
    SiteFacts,
    StateTask,
)
from behaviours.profiles.cabinet.config import CabinetConfig
from behaviours.profiles.cabinet.map_reader import SiteFileError, parse_site_map, read_json
from behaviours.profiles.cabinet.site import build_site, resolve
from behaviours.profiles.cabinet.states import (
    CabinetState,
    CabinetTrigger,
    cabinet_states,
    cabinet_transitions,
)
from behaviours.profiles.cabinet.steps.action import CabinetAction
from behaviours.profiles.cabinet.steps.drive_control import DriveController
from behaviours.profiles.cabinet.steps.fitting import Fitting
from behaviours.profiles.cabinet.steps.mission import Mission, show_graph
from behaviours.profiles.cabinet.steps.relocate import Relocate
from behaviours.profiles.cabinet.task_list import parse_task_list
from behaviours.service import Service, TaskService

if TYPE_CHECKING:
    from behaviours.context import RobotContext

_POSE_EVENT_S = 0.5


class CabinetProfile(BaseProfile):
    name = "cabinet"
    devices = ("motors", "encoders", "lidar")

    def __init__(self) -> None:
        self.mission: Mission | None = None
        self._ctx: RobotContext | None = None

    def mission_states(self) -> list[str | dict[str, Any]]:
        return cabinet_states()

    def mission_transitions(self) -> list[dict[str, Any]]:
        return cabinet_transitions()

    def services(self, ctx: RobotContext) -> list[Service]:
        d = ctx.devices
        if d.encoders is None or d.motors is None or d.lidar is None:
            msg = "the cabinet profile needs motors, encoders and a lidar"
            raise RuntimeError(msg)
        odometry = Odometry.from_settings(ctx.settings)
        source = str(getattr(ctx.settings, "source", "") or "")
        base_dir = None if not source or source.startswith("<") else str(Path(source).parent)
        mission = self.mission = Mission(CabinetConfig.from_settings(ctx.settings), odometry,
                                         base_dir)
        self._ctx = ctx
        lidar = d.lidar

        async def localisation(ready: Any) -> None:
            """Scans to the mission; MCL from the fit's pose on (none before: no pose)."""
            stop = lidar.listen(mission.on_scan)
            try:
                ready()
                await mission.localised.wait()
                assert mission.nav is not None
                mission.nav.watch_scans()
                await mission.nav.service.run(lambda: None)
            finally:
                stop()

        async def autostart() -> None:
            await ctx.trigger(CoreTrigger.START_MISSION)
            await asyncio.Event().wait()

        return [
            TaskService("odometry", OdometryTracker(d.encoders, odometry).run, critical=True),
            _ReadyService("localisation", localisation, ("odometry",)),
            TaskService("cabinet.poses", lambda: self._pose_events(ctx),
                        depends_on=("localisation",)),
            TaskService("cabinet.autostart", autostart, depends_on=("localisation",)),
        ]

    async def _pose_events(self, ctx: RobotContext) -> None:
        """``nav.pose`` (the localised estimate) twice a second once the robot is fitted."""
        m = self.mission
        assert m is not None
        await m.localised.wait()
        while True:
            await asyncio.sleep(_POSE_EVENT_S)
            if m.nav is None:
                continue
            pose = m.nav.live_pose()
            ctx.emit("nav.pose", est_x_m=round(pose.x_m, 4), est_y_m=round(pose.y_m, 4),
                     est_heading_deg=round(math.degrees(pose.theta_rad), 2),
                     status=pose.status, spread_m=round(min(pose.spread_m, 99.0), 4),
                     particles=pose.particles, poses_published=m.nav.poses_published)

    # -- the init phase: the seed's four blocks -------------------------------------------
    async def _task_manager(self, ctx: RobotContext) -> None:
        m = self.mission
        assert m is not None
        m.reset_blocks()
        c = m.config
        try:
            m.task_doc = read_json(resolve(c.task_file, m.base_dir), c.task_file)
        except SiteFileError as exc:
            await self._init_failed(ctx, "task_manager", exc.problems)
            return
        m.block_status["task_manager"] = "ready"
        ctx.emit("init.task_manager", blocks=list(m.block_modes), task_file=c.task_file)
        await ctx.trigger(CabinetTrigger.TASKS_READ)

    async def _perceptor(self, ctx: RobotContext) -> None:
        m = self.mission
        assert m is not None and self._ctx is not None
        c = m.config
        try:
            map_path = resolve(c.map_file, m.base_dir)
            site_map = parse_site_map(read_json(map_path, c.map_file), c.map_file,
                                      map_path.parent)
            m.tasks = parse_task_list(m.task_doc, c.task_file, site_map)
            site = build_site(site_map, m.tasks, c, c.map_file)
        except SiteFileError as exc:
            await self._init_failed(ctx, "perceptor", exc.problems)
            return
        m.site = site
        m.remaining = list(m.tasks.tasks)
        m.current, m.done, m.skipped = None, [], []
        if m.nav is None:  # the global map: the navigation stack on the map's grid
            d = ctx.devices
            assert d.motors is not None and d.lidar is not None
            m.nav = NavStack(ctx.settings, d.motors, d.lidar, m.odometry,
                             front_range=d.front_range, emit=ctx.emit, grid=site.grid,
                             telemetry=ctx.telemetry)
            m.matcher = ScanMatcher(site.field, site.site_map.wall_array(),
                                    MatchConfig(min_score=c.fit_min_score, margin=c.fit_margin))
        m.block_status["perceptor"] = "ready"
        ctx.emit("init.perceptor", walls=len(site_map.walls), doors=len(site_map.doors),
                 rooms=len(site_map.rooms), cabinets=[cab.name for cab in site_map.cabinets],
                 tasks=[t.cabinet for t in m.tasks.tasks], order=m.tasks.order,
                 on_unreachable=m.tasks.on_unreachable)
        await ctx.trigger(CabinetTrigger.MAP_READ)

    async def _path_planner(self, ctx: RobotContext) -> None:
        m = self.mission
        assert m is not None and m.site is not None
        graph = m.site.graph
        graph.broken.clear()
        m.block_status["path_planner"] = "ready"
        show_graph(ctx.telemetry, m)
        links = sorted({tuple(sorted((a, b))) for a, out in graph.links.items() for b in out})
        ctx.emit("graph.built", nodes=[[n.name, round(n.x_m, 3), round(n.y_m, 3)]
                                       for n in graph.nodes.values()],
                 links=[list(k) for k in links])
        await ctx.trigger(CabinetTrigger.GRAPH_BUILT)

    async def _drive_controller(self, ctx: RobotContext) -> None:
        m = self.mission
        assert m is not None and m.nav is not None
        m.drive = DriveController(m.nav.motors, ctx.settings, m.odometry.wheel_base_m,
                                  m.odom_pose if not m.localised.is_set() else m.map_pose)
        m.block_status["drive_controller"] = "ready"
        m.local_points.clear()
        m.turned_rad, m.room_middle_tried, m.best_score, m.fits = 0.0, False, 0.0, 0
        m.last_node = m.next_node = None
        ctx.emit("init.drive_controller", heading_pid=[m.drive.heading.kp, m.drive.heading.ki,
                                                       m.drive.heading.kd])
        await ctx.trigger(CabinetTrigger.CONTROLLERS_READY)

    async def _init_failed(self, ctx: RobotContext, block: str, problems: list[str]) -> None:
        m = self.mission
        assert m is not None
        m.block_status[block] = "failed"
        ctx.emit("mission.failed", block=block, reason="; ".join(problems), problems=problems)
        await ctx.trigger(CabinetTrigger.INIT_FAILED, reason=problems[0] if problems else block)

    def state_tasks(self) -> dict[str, StateTask]:
        fit, rel, act = _Late(self, Fitting), _Late(self, Relocate), _Late(self, CabinetAction)
        s = CabinetState
        return {
            s.TASK_MANAGER: self._task_manager, s.PERCEPTOR: self._perceptor,
            s.PATH_PLANNER: self._path_planner, s.DRIVE_CONTROLLER: self._drive_controller,
            s.FIT: fit.step(Fitting.fit),
            s.CHANGE_ORIENTATION: fit.step(Fitting.change_orientation),
            s.DRIVE: fit.step(Fitting.drive),
            s.GO_ROOM_MIDDLE: fit.step(Fitting.go_room_middle),
            s.CREATE_PATH: rel.step(Relocate.create_path),
            s.PROCEED_PATH: rel.step(Relocate.proceed_path),
            s.DRIVE_TO_NODE: rel.step(Relocate.drive_to_node),
            s.BREAK_LINK: rel.step(Relocate.break_link),
            s.RESET_LINKS: rel.step(Relocate.reset_links),
            s.FACE_FRONT: act.step(CabinetAction.face_front),
            s.APPROACH: act.step(CabinetAction.approach),
            s.ACT: act.step(CabinetAction.act),
            s.REPORT: act.step(CabinetAction.report),
            s.BACK_OFF: act.step(CabinetAction.back_off),
        }

    def on_enter(self, state: str, ctx: RobotContext) -> None:
        m = self.mission
        if state == CabinetState.FAILED and m is not None and m.drive is not None:
            m.path = []

    def site_facts(self, ctx: RobotContext) -> SiteFacts:
        """The pose on its site map, and the cabinet task in hand."""
        m = self.mission
        if m is None:
            return SiteFacts()
        job = f"cabinet {m.current.cabinet}" if m.current is not None else None
        if m.nav is None:
            return SiteFacts(job=job)
        return m.nav.site_facts(job, Path(m.config.map_file).stem)

    def status(self) -> dict[str, Any]:
        """The navigation figures for ``robotctl sensors`` (pose, spread, scan rate)."""
        m = self.mission
        if m is None or m.nav is None:
            return {}
        return m.nav.status()

    def mission_status(self) -> dict[str, Any]:
        """The task list, the current path and the broken links for ``robotctl status``."""
        return {} if self.mission is None else self.mission.status()

    def control_methods(self, ctx: RobotContext) -> dict[str, ControlMethod]:
        async def links(_params: dict[str, Any]) -> dict[str, Any]:
            site = self._site()
            graph = site.graph
            all_links = sorted({tuple(sorted((a, b))) for a, out in graph.links.items()
                                for b in out})
            return {"links": [[a, b, round(graph.links[a][b], 3), graph.is_open(a, b)]
                              for a, b in all_links],
                    "broken": [list(k) for k in graph.broken_links()],
                    "resets_this_task": graph.resets_this_task}

        async def reset_links(_params: dict[str, Any]) -> dict[str, Any]:
            graph = self._site().graph
            opened = len(graph.broken)
            graph.broken.clear()  # by hand: does not count against the task's budget
            ctx.emit("links.reset", opened=opened, by="control")
            return {"opened": opened}

        return {"cabinet.links": links, "cabinet.reset_links": reset_links}

    def _site(self) -> Any:
        if self.mission is None or self.mission.site is None:
            msg = "the map is not read yet (mission.init.perceptor)"
            raise ControlRefused(msg)
        return self.mission.site


_Phase = TypeVar("_Phase", Fitting, Relocate, CabinetAction)


class _Late(Generic[_Phase]):
    """A phase's step tasks, bound to the mission once ``services`` has made it."""

    def __init__(self, profile: CabinetProfile, kind: Callable[[Mission], _Phase]) -> None:
        self.profile = profile
        self.kind: Callable[[Mission], _Phase] = kind
        self.obj: _Phase | None = None

    def step(self, method: Callable[[_Phase, RobotContext], Awaitable[None]]) -> StateTask:
        async def run(ctx: RobotContext) -> None:
            m = self.profile.mission
            assert m is not None
            if self.obj is None or self.obj.m is not m:
                self.obj = self.kind(m)
            await method(self.obj, ctx)
        return run


class _ReadyService:
    """A service whose coroutine says itself when it is ready."""

    critical = False

    def __init__(self, name: str, run: Any, depends_on: tuple[str, ...]) -> None:
        self.name = name
        self._run = run
        self.depends_on = depends_on

    async def run(self, ready: Any) -> None:
        await self._run(ready)
