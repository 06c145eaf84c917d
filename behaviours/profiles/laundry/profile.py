"""The ``laundry`` profile: mission states that mirror the request lifecycle the robot lives.

``mission.to_room`` (following the line to a customer's room), ``mission.at_room`` (waiting
for the customer to load or unload), ``mission.to_base`` and ``mission.at_base``. Directives
come from the fleet server's data exchange when ``fleet.url`` is set, otherwise from the
local route in the ``laundry`` section.
"""

from __future__ import annotations

import asyncio
import os
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import structlog

from behaviours.beacons.arrival import Arrival
from behaviours.beacons.tracker import BeaconTracker
from behaviours.line.follow import LineFollower, LineLostError
from behaviours.machine_tables import CoreTrigger
from behaviours.motion.obstacle_guard import ObstacleGuard
from behaviours.persistence import MissionRecord
from behaviours.profile import BaseProfile, SiteFacts, StateTask
from behaviours.profiles.laundry.base_queue import BaseQueue
from behaviours.profiles.laundry.directive import Directive
from behaviours.profiles.laundry.fleet_link import FleetLink, fleet_client, read_token, token_path
from behaviours.profiles.laundry.load_check import LoadCheck
from behaviours.profiles.laundry.local_route import LocalRoute
from behaviours.profiles.laundry.memory import LAUNDRY_MISSION, LaundryMemory
from behaviours.profiles.laundry.navigator import Navigator
from behaviours.profiles.laundry.report import RobotReport
from behaviours.profiles.laundry.states import (
    FOLLOWING,
    MISSION_STATES,
    MISSION_TRANSITIONS,
)
from behaviours.service import Service, TaskService
from hal.devices import Motors

if TYPE_CHECKING:
    from behaviours.context import RobotContext

log = structlog.get_logger(__name__)


class LaundryProfile(BaseProfile):
    name = "laundry"
    devices = ("motors", "encoders", "front_range", "camera", "beacons", "load_cell")

    def __init__(self) -> None:
        self.follower: LineFollower | None = None
        self.navigator: Navigator | None = None
        self.route: LocalRoute | None = None
        self.fleet: FleetLink | None = None
        self.memory: LaundryMemory | None = None

    @property
    def reports_itself(self) -> bool:
        """Its data exchange carries the site status (with ``fleet.url``; without one it
        reports to nobody)."""
        return True

    def mission_records(self) -> tuple[MissionRecord, ...]:
        return (LAUNDRY_MISSION,)

    def site_facts(self, ctx: RobotContext) -> SiteFacts:
        """The last room it arrived at (a robot on a line has no map pose); its request is
        the server's to name."""
        return SiteFacts(place=self.memory.last_room if self.memory is not None else None)

    def mission_states(self) -> list[str | dict[str, Any]]:
        return list(MISSION_STATES)

    def mission_transitions(self) -> list[dict[str, Any]]:
        return [dict(t) for t in MISSION_TRANSITIONS]

    def services(self, ctx: RobotContext) -> list[Service]:
        d = ctx.devices
        if d.camera is None or d.motors is None or d.beacons is None:
            msg = "the laundry profile needs a camera, the motor board and a BLE scanner"
            raise RuntimeError(msg)
        tracker = BeaconTracker.from_settings(d.beacons, ctx.settings)
        tracker.telemetry = ctx.telemetry
        arrival = Arrival.from_settings(tracker, ctx.settings)
        load = LoadCheck.from_settings(d.load_cell, ctx.settings) if d.load_cell else None
        wheels: Motors = d.motors
        guard = None
        if d.front_range is not None:
            wheels = guard = ObstacleGuard(d.motors, d.front_range, ctx.settings, ctx.emit)
        self.follower = LineFollower(d.camera, wheels, ctx.settings, telemetry=ctx.telemetry)
        memory = LaundryMemory(ctx, str(ctx.settings.get("laundry.base_room")))
        self.memory = memory
        navigator = Navigator(ctx, tracker, arrival, self.follower.set_follow_colour, memory)
        self.navigator = navigator
        sensing: list[Callable[[], Any]] = [tracker.run, arrival.run]
        if load is not None:
            sensing.append(load.run)

        async def run_sensing() -> None:
            async with asyncio.TaskGroup() as group:
                for run in sensing:
                    group.create_task(run())

        services: list[Service] = [TaskService("laundry.sensing", run_sensing, critical=True)]
        base_room = str(ctx.settings.get("laundry.base_room"))
        queue = BaseQueue(ctx, tracker, guard, on_queued=lambda: memory.arrived(base_room))
        services.append(TaskService("laundry.base_queue", queue.run))
        url = str(ctx.settings.get("fleet.url"))
        if url:
            report = RobotReport(ctx.settings.get("robot.name"), ctx.wall_clock, tracker,
                                 arrival, load, d.front_range, holding=memory.report,
                                 ctx=ctx, guard=guard, queue=queue,
                                 facts=lambda: self.site_facts(ctx))
            client = fleet_client(url, d.network, str(ctx.settings.get("fleet.ca_file")))

            async def follow(directive: Directive) -> None:
                # What the answer means the robot holds is on disk before the robot acts on it.
                await memory.observe(directive)
                await navigator.apply(directive)

            def on_directive(directive: Directive) -> None:
                asyncio.get_running_loop().create_task(follow(directive))

            # Read once at start; a missing or unreadable file stops the start with its path.
            path = token_path(str(ctx.settings.get("fleet.token_file")), os.environ)
            self.fleet = FleetLink(client, ctx.settings.get("robot.name"), report.build,
                                   on_directive, period_s=ctx.settings.get("fleet.period_s"),
                                   grace_s=ctx.settings.get("laundry.server_grace_s"),
                                   token=read_token(path) if path is not None else None)
            services.append(TaskService("laundry.fleet", self.fleet.run,
                                  depends_on=("laundry.sensing",)))
        else:
            s = ctx.settings
            self.route = LocalRoute(list(s.get("laundry.route")), dict(s.get("laundry.beacons")),
                                    s.get("laundry.base_room"), load, navigator.apply,
                                    follow_color=s.get("laundry.follow_color") or None,
                                    load_wait_s=s.get("laundry.load_wait_s"))
            arrival.on_change(self._route_arrival)
            services.append(TaskService("laundry.route", self.route.run,
                                  depends_on=("laundry.sensing",)))
        return services

    def _route_arrival(self, inside: bool) -> None:
        if inside and self.route is not None and self.navigator is not None:
            self.route.arrived(self.navigator.arrived_room)

    def state_tasks(self) -> dict[str, StateTask]:
        return dict.fromkeys(FOLLOWING, self._follow)

    async def _follow(self, ctx: RobotContext) -> None:
        assert self.follower is not None
        try:
            await self.follower.run()
        except LineLostError as exc:
            ctx.emit("line.lost", error=str(exc))
            log.error("laundry.line_lost", error=str(exc))
            if self.navigator is not None:
                self.navigator.line_lost()
            await ctx.trigger(CoreTrigger.FAULT, code="line_lost", reason=str(exc))
