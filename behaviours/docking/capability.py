"""Docking as a capability a profile takes in: the state tasks of every docking state, and
the watch that runs for the whole of ``docking``.

A profile with dock IR receivers plugs ``Docking.machine_part()`` (the ``docking`` root
state's phases and section 4's counting: ``behaviours.docking.machine_part``) into the machine,
merges ``Docking.state_tasks()`` into its own and fires ``go_dock``. The watch
sends the robot to ``recovery`` (motors stopped there) when the dock IR device is lost, and
fires ``signal_lost`` when no dock beam was seen for ``docking.signal_lost_s`` while it is
closing in on the dock.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from typing import TYPE_CHECKING

import structlog

from behaviours.docking import approach, contact, search, station
from behaviours.docking.align import ALIGN_LOOP, run_align
from behaviours.docking.machine_part import docking_part
from behaviours.docking.senses import (
    DOCKED_RECORD,
    DockingRun,
    DockingUnavailable,
    DockSenses,
    PhaseLoop,
    show_dock,
)
from behaviours.docking.tables import DockState, DockTrigger
from behaviours.machine_part import MachinePart
from behaviours.motion.odometry import Odometry
from behaviours.persistence import Persisted
from behaviours.profile import StateTask

if TYPE_CHECKING:
    from behaviours.context import RobotContext

log = structlog.get_logger(__name__)

WATCH_PERIOD_S = 0.1
WATCHED = (DockState.POSITION, DockState.APPROACH, DockState.ALIGN, DockState.DOCK)
"""Where a lost beam is a lost signal (the search looks for it; on the dock it may hide)."""
PhaseTask = Callable[["RobotContext", DockSenses], "object"]


class Docking:
    """The docking behaviours of one robot.

    Args:
        odometry: the robot's wheel odometry (kept current by the profile's tracker).
        next_job: in ``standby``, returns when the robot should undock (None: stay).
    """

    def __init__(self, odometry: Callable[[], Odometry | None],
                 next_job: station.NextJob | None = None) -> None:
        self._odometry = odometry
        self.next_job = next_job
        self.run = DockingRun()
        self._kept: Persisted | None = None

    def machine_part(self, ctx: RobotContext) -> MachinePart:
        """The ``docking`` root state's phases, transitions and callbacks."""
        return docking_part(ctx)

    def senses(self, ctx: RobotContext) -> DockSenses:
        odometry = self._odometry()
        if odometry is None:
            msg = "docking needs wheel odometry (the profile's encoders)"
            raise DockingUnavailable(msg)
        return DockSenses.from_ctx(ctx, odometry, self.run, self.kept(ctx))

    def kept(self, ctx: RobotContext) -> Persisted:
        """Whether the robot is docked, restored from the store on first use."""
        if self._kept is None:
            self._kept = Persisted(ctx.store, DOCKED_RECORD)
        return self._kept

    def state_tasks(self) -> dict[str, StateTask]:
        def phase(fn: Callable[[RobotContext, DockSenses], object]) -> StateTask:
            async def task(ctx: RobotContext) -> None:
                await fn(ctx, self.senses(ctx))  # type: ignore[misc]
            return task

        return {
            DockState.DOCKING: self.watch,
            DockState.SEARCH: phase(search.run_search),
            DockState.POSITION: phase(approach.run_position),
            DockState.APPROACH: phase(approach.run_approach),
            DockState.ALIGN: phase(run_align),
            DockState.DOCK: phase(contact.run_dock),
            DockState.CHARGING: phase(station.charging),
            DockState.EMPTYING: phase(station.run_emptying),
            DockState.STANDBY: phase(lambda c, s: station.run_standby(c, s, self.next_job)),
            DockState.UNDOCK: phase(station.undock),
        }

    @staticmethod
    def phase_loops() -> tuple[PhaseLoop, ...]:
        """The phases whose ``state_tasks`` run their sub-states' handlers (``run_phase``)."""
        return (search.SEARCH_LOOP, approach.POSITION_LOOP, approach.APPROACH_LOOP,
                ALIGN_LOOP, contact.DOCK_LOOP, station.EMPTYING_LOOP)

    async def watch(self, ctx: RobotContext) -> None:
        """For the whole of ``docking``: the dock IR device's health and the beam's presence."""
        self.run.reset()
        try:
            senses = self.senses(ctx)
        except DockingUnavailable as exc:
            await ctx.trigger(DockTrigger.DOCK_IR_LOST, reason=str(exc))
            return
        self.run.ir_errors = int(senses.dock_ir.status().get("line_errors", 0) or 0)
        loop = asyncio.get_running_loop()
        await asyncio.sleep(senses.config.ir_stale_s)  # the first readings after a start
        last_seen = loop.time()
        edges_then = senses.ir_edges()
        while True:
            await asyncio.sleep(WATCH_PERIOD_S)
            trouble = senses.ir_trouble()
            if trouble is not None:
                log.warning("dock.ir_lost", reason=trouble, state=ctx.state)
                await senses.mover.stop()
                await ctx.trigger(DockTrigger.DOCK_IR_LOST, reason=trouble)
                return
            state = ctx.state
            if ctx.telemetry.enabled:
                show_dock(ctx.telemetry, senses)
            if senses.view().dock_seen() or senses.contact_mv() > 0 \
                    or not state.startswith(WATCHED):
                last_seen = loop.time()
                edges_then = senses.ir_edges()
            elif loop.time() - last_seen > senses.config.signal_lost_s:
                reason = f"{state}: no dock beam for {loop.time() - last_seen:.1f} s"
                if senses.ir_edges() == edges_then:
                    # Not a pulse on any line, not even noise: the receivers' cable is out or
                    # they are all covered. Nothing tells those from darkness: a lost signal.
                    reason += " and no edge from any receiver (unplugged or covered?)"
                    log.warning("dock.ir_silent", state=state)
                await ctx.trigger(DockTrigger.SIGNAL_LOST, reason=reason)
                last_seen = loop.time()
                edges_then = senses.ir_edges()

    async def resume_if_docked(self, ctx: RobotContext) -> bool:
        """After a restart: a robot that was docked and still reads a good contact voltage
        carries on charging (``resume_charging``); True if it did."""
        if not self.kept(ctx)["docked"]:
            return False
        try:
            senses = self.senses(ctx)
        except DockingUnavailable:
            return False
        await asyncio.sleep(0.5)  # a DOCK line (5 Hz)
        if not senses.config.contact_ok(senses.contact_mv()):
            log.info("dock.not_docked_after_restart", contact_mv=senses.contact_mv())
            await senses.set_docked(False)
            return False
        return await ctx.trigger(DockTrigger.RESUME_CHARGING, contact_mv=senses.contact_mv())
