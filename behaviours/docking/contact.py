"""Phase 4, dock: forward onto the charging contacts and make sure they charge.

``slow_forward`` closes in on the aligned heading, straight (odometry holds it; the front
pair saturates in the last half metre and tells nothing there)
until the contacts show a voltage or the bumper closes (``touched``), at most
``docking.contact_travel_m`` per attempt (then ``contact_failed``). ``contact_check``: a
voltage is ``contact_made``; none is ``no_contact`` and ``align_check`` decides between
pushing on (``alignment_ok``) and ``align_lost`` (the bumper hit the station's body, or no
beam is seen any more). ``voltage_detect`` holds the voltage for ``docking.contact_hold_s``:
within ``docking.contact_min_mv``..``contact_max_mv`` throughout is ``voltage_ok`` (outside
them is never docked: ``voltage_abnormal``). ``motor_stop`` stops the wheels. ``retry`` backs
off and checks the contacts off the dock (they must read 0) before aligning again.
"""

from __future__ import annotations

import asyncio
from typing import TYPE_CHECKING

from behaviours.docking.reverse import back_up
from behaviours.docking.senses import DockSenses, PhaseLoop
from behaviours.docking.tables import DockState, DockTrigger

if TYPE_CHECKING:
    from behaviours.context import RobotContext

CHECK_S = 0.25
MAX_PUSHES = 3
PUSH_M = 0.02
HOLD_PERIOD_S = 0.05


async def slow_forward(ctx: RobotContext, senses: DockSenses) -> None:
    run, cfg, mover = senses.run, senses.config, senses.mover
    if run.travel_left_m <= 0 and run.align_checks == 0:
        run.travel_left_m = cfg.contact_travel_m

    def touched() -> bool:
        return senses.contact_mv() > 0 or senses.bumped()

    hold = senses.dock_dir()
    view = senses.view
    if not view().located("force_field"):
        run.travel_left_m -= await mover.straight(
            run.travel_left_m, cfg.approach_mps, heading_rad=hold,
            until=lambda: touched() or view().located("force_field"))
    if not touched():
        run.travel_left_m -= await mover.straight(
            max(0.0, run.travel_left_m), cfg.dock_mps, heading_rad=hold, until=touched)
    if touched():
        await ctx.trigger(DockTrigger.TOUCHED, contact_mv=senses.contact_mv(),
                          bumped=senses.bumped())
    else:
        await ctx.trigger(DockTrigger.CONTACT_FAILED,
                          reason=f"no contact after {cfg.contact_travel_m:.2f} m forward")


async def contact_check(ctx: RobotContext, senses: DockSenses) -> None:
    await senses.mover.send(0.0, 0.0)
    await asyncio.sleep(CHECK_S)  # the DOCK line comes at 5 Hz
    if senses.contact_mv() > 0:
        await ctx.trigger(DockTrigger.CONTACT_MADE, contact_mv=senses.contact_mv())
    else:
        await ctx.trigger(DockTrigger.NO_CONTACT)


async def align_check(ctx: RobotContext, senses: DockSenses) -> None:
    run = senses.run
    run.align_checks += 1
    if senses.bumped() and senses.contact_mv() == 0:
        # The nose met the station's body beside the pads: off the axis.
        await back_up(ctx, senses, 0.05, senses.config.dock_mps, why="align_check")
        await ctx.trigger(DockTrigger.ALIGN_LOST,
                          reason="bumped the station beside the contacts")
    elif not senses.view().dock_seen():
        await ctx.trigger(DockTrigger.ALIGN_LOST, reason="no dock beam at the contacts")
    elif run.align_checks > MAX_PUSHES:
        await ctx.trigger(DockTrigger.CONTACT_FAILED,
                          reason=f"no contact after {MAX_PUSHES} pushes")
    else:
        run.travel_left_m = max(run.travel_left_m, PUSH_M)
        await ctx.trigger(DockTrigger.ALIGNMENT_OK)


async def voltage_detect(ctx: RobotContext, senses: DockSenses) -> None:
    cfg = senses.config
    loop = asyncio.get_running_loop()
    end = loop.time() + cfg.contact_hold_s
    worst = senses.contact_mv()
    while True:
        mv = senses.contact_mv()
        if not cfg.contact_ok(mv):
            worst = mv
            break
        if loop.time() >= end:
            break
        await asyncio.sleep(HOLD_PERIOD_S)
    if cfg.contact_ok(worst):
        await ctx.trigger(DockTrigger.VOLTAGE_OK, contact_mv=worst)
    else:
        await ctx.trigger(
            DockTrigger.VOLTAGE_ABNORMAL,
            reason=f"contact voltage {worst} mV outside {cfg.contact_min_mv}-"
                   f"{cfg.contact_max_mv} mV")


async def motor_stop(ctx: RobotContext, senses: DockSenses) -> None:
    await senses.mover.stop()
    await senses.set_docked(True)
    await ctx.trigger(DockTrigger.STOPPED, contact_mv=senses.contact_mv())


async def retry(ctx: RobotContext, senses: DockSenses) -> None:
    """Back off, then check the contacts off the dock (section 4: "check contacts")."""
    cfg = senses.config
    await back_up(ctx, senses, cfg.back_off_m, cfg.approach_mps / 2, why="retry")
    await asyncio.sleep(CHECK_S)
    mv = senses.contact_mv()
    ctx.emit("dock.contacts_checked", contact_mv=mv, ok=mv == 0)
    senses.run.travel_left_m = 0.0
    senses.run.align_checks = 0
    await ctx.trigger(DockTrigger.BACKED_OFF)


DOCK_LOOP = PhaseLoop(DockState.DOCK, {
    DockState.SLOW_FORWARD: slow_forward,
    DockState.CONTACT_CHECK: contact_check,
    DockState.ALIGN_CHECK: align_check,
    DockState.VOLTAGE_DETECT: voltage_detect,
    DockState.MOTOR_STOP: motor_stop,
    DockState.RETRY: retry,
})


async def run_dock(ctx: RobotContext, senses: DockSenses) -> None:
    """The ``docking.dock`` state's task (phase 4)."""
    senses.run.travel_left_m = 0.0
    senses.run.align_checks = 0
    await DOCK_LOOP.run(ctx, senses)
