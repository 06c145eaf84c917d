"""The ``survey`` profile: the robot's drivers feeding the mapping core live (``robotd map``).

It stays ``idle`` (where ``robotctl drive`` may drive it) while ``LiveMapping`` turns every
still LiDAR scan that is far enough from the last into a key scan of the growing map. With
``survey.explore`` it explores by itself (``mission.explore``: the exploring driver, to the
nearest frontier until none is left or ``survey.explore_time_limit_s``), saves the map as
``survey.save_as`` when that is set, and comes back to ``idle``. ``survey.save_map``
(``robotctl map save NAME``) writes ``NAME.pgm`` + ``NAME.yaml`` into ``survey.maps_dir``
(default: ``maps/`` in the state directory), rendered from the optimised key poses.
"""

from __future__ import annotations

import asyncio
import math
import re
from pathlib import Path
from typing import TYPE_CHECKING, Any, Final

import structlog

from behaviours.machine_tables import CoreTrigger, mission_children
from behaviours.motion.odometry import Odometry
from behaviours.motion.waypoint_drive import OdometryTracker
from behaviours.nav.mapping.explore import Explorer
from behaviours.nav.mapping.live import LiveMapping
from behaviours.nav.mapping.map_save import write_map
from behaviours.profile import BaseProfile, ControlMethod, ControlRefused, StateTask
from behaviours.service import Service, TaskService
from hal.options import Option, Section

if TYPE_CHECKING:
    from behaviours.context import RobotContext

log = structlog.get_logger(__name__)

SURVEY = Section("survey", "Making the site's map (robotd map): live mapping, exploring.", (
    Option("explore", "bool", False,
           "Explore by itself to the nearest frontier until none is left (else it waits, "
           "idle, for a technician's robotctl drive)."),
    Option("explore_time_limit_s", "float", 1800.0, "Exploring stops after this long.",
           min=1, max=86400),
    Option("step_m", "float", 0.3,
           "The exploring drive stops this often for a still scan (a key scan).",
           min=0.05, max=2.0),
    Option("save_as", "str", "",
           "Once exploring is done, save the map under this name ('' : only when asked)."),
    Option("maps_dir", "str", "",
           "Where maps are saved ('' : maps/ in the state directory)."),
    Option("start_x_m", "float", 0.0, "The map-frame pose the robot starts at: x.",
           min=-10000, max=10000),
    Option("start_y_m", "float", 0.0, "... y.", min=-10000, max=10000),
    Option("start_heading_deg", "float", 0.0, "... heading.", min=-360, max=360),
))

_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}")
SAVE_MAP = "save_map"


class SurveyState:
    EXPLORE: Final = "mission.explore"


class SurveyProfile(BaseProfile):
    name = "survey"
    devices = ("motors", "encoders", "lidar")

    def __init__(self) -> None:
        self.live: LiveMapping | None = None
        self.odometry: Odometry | None = None
        self.saved: list[str] = []

    def mission_states(self) -> list[str | dict[str, Any]]:
        return mission_children(SurveyState.EXPLORE)

    def services(self, ctx: RobotContext) -> list[Service]:
        d = ctx.devices
        if d.encoders is None or d.motors is None or d.lidar is None:
            msg = "the survey profile needs motors, encoders and a lidar"
            raise RuntimeError(msg)
        odometry = self.odometry = Odometry.from_settings(ctx.settings)
        s = ctx.settings
        start = (s.get("survey.start_x_m"), s.get("survey.start_y_m"),
                 math.radians(s.get("survey.start_heading_deg")))

        def odom() -> tuple[float, float, float]:
            p = odometry.pose()
            return (p.x_m, p.y_m, p.theta_rad)

        live = self.live = LiveMapping(odom, start=start, emit=ctx.emit,
                                       telemetry=ctx.telemetry)
        lidar = d.lidar

        async def mapping() -> None:
            stop = lidar.listen(live.on_scan)
            ctx.emit("mapping.start", start_x_m=start[0], start_y_m=start[1],
                     start_heading_deg=round(math.degrees(start[2]), 2))
            try:
                if s.get("survey.explore"):
                    await ctx.trigger(CoreTrigger.START_MISSION)
                await asyncio.Event().wait()
            finally:
                stop()
                live.close()

        return [
            TaskService("odometry", OdometryTracker(d.encoders, odometry,
                                                    telemetry=ctx.telemetry).run,
                        critical=True),
            TaskService("mapping", mapping, depends_on=("odometry",), critical=True),
        ]

    def state_tasks(self) -> dict[str, StateTask]:
        return {SurveyState.EXPLORE: self._explore}

    async def _explore(self, ctx: RobotContext) -> None:
        live, odometry = self.live, self.odometry
        motors = ctx.devices.motors
        assert live is not None and odometry is not None and motors is not None
        s = ctx.settings
        explorer = Explorer(live, motors, odometry, s, step_m=s.get("survey.step_m"),
                            time_limit_s=s.get("survey.explore_time_limit_s"), emit=ctx.emit)
        result = await explorer.run()
        log.info("mapping.explore_done", reason=result.reason, rounds=result.rounds)
        name = s.get("survey.save_as")
        if name:
            await self._save(ctx, name)
        await ctx.trigger(CoreTrigger.MISSION_DONE)

    def control_methods(self, ctx: RobotContext) -> dict[str, ControlMethod]:
        """``survey.save_map`` (``robotctl map save NAME``)."""

        async def save_map(params: dict[str, Any]) -> dict[str, Any]:
            name = params.get("name")
            if not isinstance(name, str) or not _NAME.fullmatch(name):
                msg = ("name: expected a file name of letters, digits, '_', '.', '-' (no "
                       f"directory), got {name!r}")
                raise ValueError(msg)
            return await self._save(ctx, name)

        return {f"{self.name}.{SAVE_MAP}": save_map}

    async def _save(self, ctx: RobotContext, name: str) -> dict[str, Any]:
        live = self.live
        if live is None or not live.mapper.key_scans:
            msg = "no key scan yet: nothing to save (drive the robot a little first)"
            raise ControlRefused(msg)
        grid, poses = await live.final_map()
        yaml = write_map(grid, self._maps_dir(ctx) / name)
        keys = live.mapper.key_scans
        x, y, theta = live.pose()
        self.saved.append(str(yaml))
        figures = {"yaml": str(yaml), "key_scans": len(keys),
                   "loops_closed": live.mapper.graph.loop_closures(),
                   "cells": [grid.width, grid.height], "resolution_m": grid.resolution_m,
                   "pose": [round(x, 4), round(y, 4), round(math.degrees(theta), 3)]}
        ctx.emit("mapping.saved", **figures,
                 key_poses=[[round(p[0], 4), round(p[1], 4), round(p[2], 5)] for p in poses])
        return figures

    def _maps_dir(self, ctx: RobotContext) -> Path:
        configured = ctx.settings.get("survey.maps_dir")
        if configured:
            return Path(configured)
        if ctx.state_dir is None:
            msg = "survey.maps_dir is not set and the daemon has no state directory"
            raise ControlRefused(msg)
        return Path(ctx.state_dir) / "maps"

    def mission_status(self) -> dict[str, Any]:
        """``robotctl status``: the mapping's figures."""
        if self.live is None:
            return {}
        out = self.live.status()
        out["saved"] = self.saved[-1] if self.saved else None
        return out
