"""The ``vacuum`` profile: clean, check the battery now and then, dock below the threshold.

Mission states (seed section 1): ``mission.cleaning`` and ``mission.battery_check``; every
``vacuum.battery_check_s`` the robot passes through the check (each a logged transition):
at or above ``docking.battery_threshold_pct`` it cleans on (``battery_ok``), below it
``go_dock``. A battery that cannot be read (no reading, or none for ``vacuum.battery_stale_s``)
is neither: the robot cannot know when to dock, so the check reports the fault
``battery_unreadable`` (``fault``: recovery, the motors stopped; ``robotctl status`` shows
it, and a robot that reports to a fleet server sends it there). Docking is the shared
capability (``behaviours.docking``); in standby the next clean is the schedule's
(``vacuum.schedule``, the seed's "cleaning scheduled?"), and undocking leads back into
``mission.cleaning``.
"""

from __future__ import annotations

import asyncio
import random
from typing import TYPE_CHECKING, Any, Final

import structlog

from behaviours.docking.capability import Docking
from behaviours.docking.tables import DockTrigger
from behaviours.machine_part import MachinePart
from behaviours.machine_tables import CoreTrigger, RootState, mission_children
from behaviours.motion.moves import Mover
from behaviours.motion.odometry import Odometry
from behaviours.motion.waypoint_drive import OdometryTracker
from behaviours.profile import BaseProfile, SiteFacts, StateTask
from behaviours.profiles.vacuum.cleaning import Coverage
from behaviours.profiles.vacuum.config import VacuumConfig
from behaviours.profiles.vacuum.schedule import Schedule
from behaviours.service import Service, TaskService

if TYPE_CHECKING:
    from behaviours.context import RobotContext

log = structlog.get_logger(__name__)

BATTERY_UNREADABLE: Final = "battery_unreadable"
"""The fault code of a battery the check cannot read."""

DEVICES = ("motors", "encoders", "battery", "servo", "dock_ir", "dock_signal",
           "dock_contacts", "bumpers", "wall", "bin", "station")


class VacuumState:
    """The mission's states (the docking ones are ``DockState``)."""

    CLEANING: Final = "mission.cleaning"
    BATTERY_CHECK: Final = "mission.battery_check"


class VacuumTrigger:
    """The mission's own triggers (below the threshold it fires ``DockTrigger.GO_DOCK``)."""

    CHECK_BATTERY: Final = "check_battery"
    BATTERY_OK: Final = "battery_ok"


async def _forever() -> None:
    await asyncio.Event().wait()


class VacuumProfile(BaseProfile):
    name = "vacuum"
    devices = DEVICES

    def __init__(self) -> None:
        self._odometry: Odometry | None = None
        self.docking = Docking(lambda: self._odometry, next_job=self._next_clean)
        self._rng = random.Random(0)

    def mission_states(self) -> list[str | dict[str, Any]]:
        return mission_children(VacuumState.CLEANING, VacuumState.BATTERY_CHECK)

    def mission_transitions(self) -> list[dict[str, Any]]:
        s, t = VacuumState, VacuumTrigger
        return [
            {"trigger": t.CHECK_BATTERY, "source": s.CLEANING, "dest": s.BATTERY_CHECK},
            {"trigger": t.BATTERY_OK, "source": s.BATTERY_CHECK, "dest": s.CLEANING},
        ]

    def services(self, ctx: RobotContext) -> list[Service]:
        encoders = ctx.devices.encoders
        if encoders is None:
            msg = "the vacuum profile needs encoders"
            raise RuntimeError(msg)
        odometry = self._odometry = Odometry.from_settings(ctx.settings)
        self._rng = random.Random(str(ctx.settings.get("robot.name")))

        async def autostart() -> None:
            """Once booted: back to charging if it was docked, else start cleaning."""
            if not await self.docking.resume_if_docked(ctx) \
                    and ctx.settings.get("vacuum.autostart"):
                await ctx.trigger(CoreTrigger.START_MISSION)
            await _forever()

        return [TaskService("odometry", OdometryTracker(encoders, odometry,
                                                        telemetry=ctx.telemetry).run,
                            critical=True),
                TaskService("vacuum.autostart", autostart, depends_on=("odometry",))]

    def site_facts(self, ctx: RobotContext) -> SiteFacts:
        """Its odometry pose: no map, so the frame is ``odom`` (where it started)."""
        odometry = self._odometry
        if odometry is None:
            return SiteFacts()
        pose = odometry.pose()
        return SiteFacts(x_m=pose.x_m, y_m=pose.y_m, theta_rad=pose.theta_rad, map_name="odom")

    def machine_parts(self, ctx: RobotContext) -> tuple[MachinePart, ...]:
        return (self.docking.machine_part(ctx),)

    def state_tasks(self) -> dict[str, StateTask]:
        return {RootState.MISSION: self._clean, VacuumState.CLEANING: self._battery_timer,
                VacuumState.BATTERY_CHECK: self._battery_check, **self.docking.state_tasks()}

    def _mover(self, ctx: RobotContext) -> Mover:
        if ctx.devices.motors is None or self._odometry is None:
            msg = "the vacuum profile needs motors and odometry"
            raise RuntimeError(msg)
        return Mover(ctx.devices.motors, self._odometry, ctx.settings)

    async def _clean(self, ctx: RobotContext) -> None:
        coverage = Coverage(self._mover(ctx), ctx.devices.bumpers, ctx.devices.wall, self._rng,
                            ctx.devices.dock_ir)
        ctx.emit("clean.start")
        await coverage.run(ctx)

    async def _battery_timer(self, ctx: RobotContext) -> None:
        await asyncio.sleep(float(ctx.settings.get("vacuum.battery_check_s")))
        await ctx.trigger(VacuumTrigger.CHECK_BATTERY)

    async def _battery_check(self, ctx: RobotContext) -> None:
        battery = ctx.devices.battery
        reading = None if battery is None else battery.latest()
        threshold = float(ctx.settings.get("docking.battery_threshold_pct"))
        stale_s = float(ctx.settings.get("vacuum.battery_stale_s"))
        age_s = None if reading is None else ctx.loop_time_s() - reading.t_s
        if reading is None or age_s is None or age_s > stale_s:
            why = ("no battery device" if battery is None else "no battery reading yet"
                   if reading is None else f"no battery reading for {age_s:.0f} s")
            log.error("clean.battery_unreadable", reason=why)
            ctx.emit("clean.battery_unreadable", reason=why)
            await ctx.trigger(CoreTrigger.FAULT, code=BATTERY_UNREADABLE,
                              reason=f"battery cannot be read ({why}): the robot cannot tell "
                                     "when to dock")
        elif reading.percent < threshold:
            ctx.emit("clean.battery_low", battery_pct=round(reading.percent, 1),
                     threshold_pct=threshold)
            await ctx.trigger(DockTrigger.GO_DOCK, reason="battery low")
        else:
            await ctx.trigger(VacuumTrigger.BATTERY_OK)

    async def _next_clean(self, ctx: RobotContext) -> None:
        """Standby: until the schedule's next start (or ``standby_s``, when set), whichever
        comes first; the seed's "No -> STANDBY" loop is this wait."""
        config = VacuumConfig.from_settings(ctx.settings)
        schedule = Schedule.parse(config.schedule, config.timezone)
        now = ctx.wall_clock()
        start = schedule.next_start(now)
        waits = [] if start is None else [(start - now).total_seconds()]
        if config.standby_s > 0:
            waits.append(config.standby_s)
        ctx.emit("clean.next", at=None if start is None else start.isoformat(),
                 in_s=None if not waits else round(min(waits), 3),
                 by="schedule" if start is not None and waits[0] == min(waits) else
                 "standby_s" if waits else None)
        if not waits:
            await asyncio.Event().wait()  # nothing scheduled: standby until told otherwise
        await asyncio.sleep(min(waits))
