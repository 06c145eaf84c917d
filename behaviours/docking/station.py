"""Section 5: on the dock. Charge; empty the dust bin into the station; wait; undock.

``charging`` watches the battery and the bin: a full bin (``docking.bin_full_pct``, once per
docking) starts ``emptying`` (door open on the bin door servo, station suction on with
``EVAC:1``, ``wait_empty`` between ``docking.empty_min_s`` and the state's 10-30 s limit until
the bin reads empty, suction off, door closed) and charging carries on; a full charge
(``docking.charge_full_pct``) is ``charged`` -> ``standby``. Contacts that lose their voltage
on the way are ``contacts_lost`` (dock again). ``standby`` waits for the robot's next job (the
profile's ``next_job``: the vacuum's cleaning schedule) and ``undock`` backs out under the
reverse guard (``behaviours.docking.reverse``) and turns round.

Whether the robot is docked survives a restart (``senses.DOCKED_RECORD``).
"""

from __future__ import annotations

import asyncio
import contextlib
import math
from collections.abc import Awaitable, Callable
from typing import TYPE_CHECKING

from behaviours.docking.reverse import back_up
from behaviours.docking.senses import DockSenses, PhaseLoop
from behaviours.docking.tables import DockState, DockTrigger
from hal.devices import LinkDown

if TYPE_CHECKING:
    from behaviours.context import RobotContext

POLL_S = 0.5
CONTACTS_GONE_S = 1.0
DOOR_S = 1.0  # the bin door servo's travel

NextJob = Callable[["RobotContext"], Awaitable[None]]
"""Returns when the robot has a job again (a cleaning schedule, a mission)."""


async def _contacts_gone_for(senses: DockSenses, since: float | None) -> float | None:
    loop = asyncio.get_running_loop()
    if senses.config.contact_ok(senses.contact_mv()):
        return None
    return loop.time() if since is None else since


async def charging(ctx: RobotContext, senses: DockSenses) -> None:
    cfg, run = senses.config, senses.run
    loop = asyncio.get_running_loop()
    await senses.set_docked(True)
    gone: float | None = None
    while True:
        gone = await _contacts_gone_for(senses, gone)
        if gone is not None and loop.time() - gone > CONTACTS_GONE_S:
            await senses.set_docked(False)
            await ctx.trigger(DockTrigger.CONTACTS_LOST, contact_mv=senses.contact_mv())
            return
        if not run.emptied and senses.bin_pct() >= cfg.bin_full_pct:
            await ctx.trigger(DockTrigger.BIN_FULL, bin_pct=senses.bin_pct())
            return
        pct = senses.battery_pct()
        if pct is not None and pct >= cfg.charge_full_pct:
            await ctx.trigger(DockTrigger.CHARGED, battery_pct=round(pct, 1))
            return
        await asyncio.sleep(POLL_S)


async def _door(senses: DockSenses, open_: bool) -> None:
    if senses.servo is not None:
        cfg = senses.config
        with contextlib.suppress(LinkDown):
            await senses.servo.set_angle(cfg.bin_door_open_deg if open_ else
                                         cfg.bin_door_closed_deg)
    await asyncio.sleep(DOOR_S)


async def _suction(senses: DockSenses, on: bool) -> None:
    if senses.station is not None:
        with contextlib.suppress(LinkDown):
            await senses.station.evacuate(on)


async def door_open(ctx: RobotContext, senses: DockSenses) -> None:
    await _door(senses, True)
    await ctx.trigger(DockTrigger.DOOR_OPENED)


async def vacuum_on(ctx: RobotContext, senses: DockSenses) -> None:
    await _suction(senses, True)
    await ctx.trigger(DockTrigger.SUCTION_ON)


async def wait_empty(ctx: RobotContext, senses: DockSenses) -> None:
    """At least ``empty_min_s``, then until the bin reads empty (the state's timeout ends it
    at ``empty_max_s`` at the latest)."""
    cfg = senses.config
    start_pct = senses.bin_pct()
    await asyncio.sleep(cfg.empty_min_s)
    loop = asyncio.get_running_loop()
    end = loop.time() + max(0.0, cfg.empty_max_s - cfg.empty_min_s)
    while senses.bin_pct() > cfg.bin_empty_pct and loop.time() < end:  # noqa: ASYNC110
        await asyncio.sleep(POLL_S)  # the BIN line is a 1 Hz reading, not an event
    await ctx.trigger(DockTrigger.BIN_EMPTIED, bin_pct=senses.bin_pct(), from_pct=start_pct)


async def vacuum_off(ctx: RobotContext, senses: DockSenses) -> None:
    await _suction(senses, False)
    await ctx.trigger(DockTrigger.SUCTION_OFF)


async def door_close(ctx: RobotContext, senses: DockSenses) -> None:
    await _door(senses, False)
    senses.run.emptied = True
    ctx.emit("dock.emptied", bin_pct=senses.bin_pct())
    await ctx.trigger(DockTrigger.DOOR_CLOSED)


async def undock(ctx: RobotContext, senses: DockSenses) -> None:
    """Back out ``undock_distance_m`` under the reverse guard (stopped early by a virtual wall
    behind or a bumper), then turn round."""
    cfg = senses.config
    await senses.set_docked(False)
    backed = await back_up(ctx, senses, cfg.undock_distance_m, cfg.approach_mps, why="undock")
    await senses.mover.turn_by(math.pi)
    await ctx.trigger(DockTrigger.UNDOCKED, backed_m=round(backed, 3))


EMPTYING_LOOP = PhaseLoop(DockState.EMPTYING, {
    DockState.DOOR_OPEN: door_open,
    DockState.VACUUM_ON: vacuum_on,
    DockState.WAIT_EMPTY: wait_empty,
    DockState.VACUUM_OFF: vacuum_off,
    DockState.DOOR_CLOSE: door_close,
})


async def run_emptying(ctx: RobotContext, senses: DockSenses) -> None:
    """The ``docking.emptying`` state's task; suction off and door shut if it is cut short."""
    try:
        await EMPTYING_LOOP.run(ctx, senses)
    finally:
        if ctx.state != DockState.CHARGING:
            await asyncio.shield(_suction(senses, False))


async def run_standby(ctx: RobotContext, senses: DockSenses, next_job: NextJob | None) -> None:
    """Wait for the next job, then ``clean_scheduled``."""
    if next_job is None:
        await asyncio.Event().wait()
        return
    await next_job(ctx)
    await ctx.trigger(DockTrigger.CLEAN_SCHEDULED)
