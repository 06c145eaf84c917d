"""Phase 3, align: onto the dock's axis by the centre beam, then square to it by the front pair.

``center_beam_search`` turns side-on to the dock and sweeps across the narrow centre beam
(+-3 deg, the last metre) both ways; the middle of the two places where the omni receiver
lost it is the axis (the decoder's window delays both losses alike, one each way, so they
cancel). The robot stops there and turns back to the dock (``fine_align``). ``signal_compare``
then compares the front pair's strengths: the pair is crossed, so a stronger left receiver
means the dock lies to the right (``left_stronger`` -> ``micro_adjust_r``); each adjustment is
a turn of half ``docking.micro_turn_deg``, halved each time the turn reverses, until L ~ R
(``balanced``). Near the axis the crossed pair's difference follows the heading closely.
"""

from __future__ import annotations

import asyncio
import math
from typing import TYPE_CHECKING

from behaviours.docking.beams import FRONT_RECEIVERS, BeamView, front_case, signal_case
from behaviours.docking.reverse import back_up
from behaviours.docking.search import FINE_DPS, PERIOD_S, scan_dock_dir
from behaviours.docking.senses import DockSenses, Handlers, PhaseLoop
from behaviours.docking.tables import DockState, DockTrigger
from behaviours.motion.moves import TURN_TOLERANCE_RAD, wrap

if TYPE_CHECKING:
    from behaviours.context import RobotContext

SWEEP_MPS = 0.05
SWEEP_FIRST_M = 0.3
SWEEP_BACK_M = 0.6
LOST_AFTER_S = 0.1
OMNI_FORWARD_M = 0.12
"""Where the omni receiver sits ahead of the robot's centre (a mounting fact: where the
beam was lost is where the omni was, not the centre)."""
MAX_COMPARES = 12
MIN_ADJUST_RAD = 2 * TURN_TOLERANCE_RAD
FINE_ARC_DEG = 60.0
"""How far a slow turn goes looking for an edge of the front pair's arc (+-25 deg)."""
FINE_INSIDE_DEG = 12.0
"""Where else to look for the arc when the pair does not see the dock facing the direction
the centre beam search left (a coarse scan can be off by 15 deg)."""
EDGE_SETTLE_S = 0.6
"""After a turn, the longest wait for the pair to see the dock (the dock's beam cycle, the
decoder's gap and the reading period: about 0.3 s)."""
BACK_OUT_MAX_M = 0.8


async def _sweep(senses: DockSenses, direction: float, max_m: float) -> float | None:
    """Drive side-on (``direction`` +1 forward, -1 back) until the centre beam, once seen,
    is lost; the position along the sweep line where it went, or None."""
    mover, view = senses.mover, senses.view
    heading = mover.heading_rad
    loop = asyncio.get_running_loop()
    seen = False
    lost_at: float | None = None

    def done() -> bool:
        # Lost for LOST_AFTER_S: one centre frame missed inside the beam (the window is
        # only a little longer than the dock's beam cycle) is not the beam's edge.
        nonlocal seen, lost_at
        here = view().sees("omni", "centre")
        seen = seen or here
        if here or not seen:
            lost_at = None
            return False
        lost_at = loop.time() if lost_at is None else lost_at
        return loop.time() - lost_at >= LOST_AFTER_S

    await mover.straight(max_m, direction * SWEEP_MPS, heading_rad=heading, until=done)
    if lost_at is None or loop.time() - lost_at < LOST_AFTER_S:
        return None
    x, y = mover.position()
    return x * math.cos(heading) + y * math.sin(heading)


async def center_beam_search(ctx: RobotContext, senses: DockSenses) -> None:
    mover = senses.mover
    dock_dir = senses.dock_dir()
    def too_close() -> bool:
        # Where the crossed pair does not tell L from R: saturated, or inside the force
        # field (right at the station, off its axis, the pair may read weak or crossed).
        return senses.strength() > senses.config.align_strength \
            or senses.view().located("force_field")

    if too_close():
        # After a failed contact or an alignment lost: back out to where it can align.
        await mover.turn_to(dock_dir)
        await back_up(ctx, senses, BACK_OUT_MAX_M, senses.config.approach_mps / 2,
                      why="center_beam_search", until=lambda: not too_close())
    # Side-on with the dock to the right, the omni receiver sits 12 cm ahead along the sweep:
    # near the axis the beam is behind it, so sweep backwards first; only in the front_right
    # beam alone (the robot off to the dock's left) does the axis lie ahead.
    towards = 1.0 if front_case(senses.view()) == DockTrigger.FRONT_RIGHT_ONLY else -1.0
    await mover.turn_to(dock_dir + math.pi / 2)
    heading = mover.heading_rad
    first = await _sweep(senses, towards, SWEEP_FIRST_M)
    second = await _sweep(senses, -towards,
                          SWEEP_BACK_M + (SWEEP_FIRST_M if first is None else 0))
    if first is None and second is not None:
        first = await _sweep(senses, towards, SWEEP_BACK_M)
    if first is None or second is None:
        await mover.turn_to(dock_dir)
        await ctx.trigger(DockTrigger.SIGNAL_LOST, reason="center_beam_search: no centre beam")
        return
    middle = (first + second) / 2
    x, y = mover.position()
    along = x * math.cos(heading) + y * math.sin(heading)
    shift = middle + OMNI_FORWARD_M - along  # the centre, not the omni, onto the axis
    await mover.straight(abs(shift), math.copysign(SWEEP_MPS * 2, shift), heading_rad=heading)
    senses.run.dock_dir_rad = heading - math.pi / 2
    await ctx.trigger(DockTrigger.CENTER_FOUND, beam_width_m=round(abs(first - second), 3))


def _both_front(view: BeamView) -> bool:
    return all(view.sees_any(r) for r in FRONT_RECEIVERS)


async def _pair_sees(senses: DockSenses) -> bool:
    """Whether both front receivers see the dock, waiting a little after a turn."""
    loop = asyncio.get_running_loop()
    end = loop.time() + EDGE_SETTLE_S
    while not _both_front(senses.view()):
        if loop.time() >= end:
            return False
        await asyncio.sleep(PERIOD_S)
    return True


async def _turn_until_lost(senses: DockSenses, sign: float, limit_rad: float) -> float | None:
    """Turn at ``FINE_DPS`` (``sign`` +1: left) until both front receivers, once seeing the
    dock, no longer do; the heading where they stopped, or None within ``limit_rad``."""
    mover, rate = senses.mover, math.radians(FINE_DPS)
    seen = _both_front(senses.view())
    last, turned = mover.heading_rad, 0.0
    result = None
    while turned < limit_rad:
        await mover.send(0.0, sign * rate)
        await asyncio.sleep(PERIOD_S)
        heading = mover.heading_rad
        turned += abs(wrap(heading - last))
        last = heading
        if _both_front(senses.view()):
            seen = True
        elif seen:
            result = heading
            break
    await mover.send(0.0, 0.0)
    return result


async def _edges_dir(senses: DockSenses, around: float) -> float | None:
    """The dock's direction from where the crossed front pair loses it turning left, then
    turning right, from inside the arc where it sees the dock: each edge is late by the
    decoder's window the way it turned, at the same rate, so their mean cancels it (the far
    edges of a two-way scan, without the way in). None when the pair does not see the dock
    facing ``around`` nor a little either side of it."""
    step = math.radians(FINE_INSIDE_DEG)
    for start in (around, around + step, around - step):
        await senses.mover.turn_to(start)
        if await _pair_sees(senses):
            break
    else:
        return None
    left = await _turn_until_lost(senses, 1.0, math.radians(FINE_ARC_DEG))
    right = None if left is None else await _turn_until_lost(
        senses, -1.0, math.radians(2 * FINE_ARC_DEG))
    if left is None or right is None:
        return None
    return wrap(right + wrap(left - right) / 2)


async def fine_align(ctx: RobotContext, senses: DockSenses) -> None:
    """On the axis: the dock's direction by a slow turn out of each side of the arc where the
    front pair sees it (a whole slow scan across it when that fails), then face it."""
    run = senses.run
    run.align_checks = 0
    run.adjust_sign = 0.0
    run.adjust_rad = math.radians(senses.config.micro_turn_deg) / 4
    before = senses.dock_dir()
    direction = await _edges_dir(senses, before)
    by = "edges"
    if direction is None:
        by = "scan"
        direction = await scan_dock_dir(senses, dps=FINE_DPS, around=before)
    ctx.emit("dock.fine_dir", by=by, off_deg=None if direction is None
             else round(math.degrees(wrap(direction - before)), 2))
    await senses.mover.turn_to(direction if direction is not None else before)
    await ctx.trigger(DockTrigger.COMPARE)


async def signal_compare(ctx: RobotContext, senses: DockSenses) -> None:
    await asyncio.sleep(0.15)  # fresh IRS lines (20 Hz) after the last turn
    signal = senses.signal()
    run = senses.run
    run.align_checks += 1
    if signal is None or run.align_checks > MAX_COMPARES:
        await ctx.trigger(DockTrigger.BALANCED, compares=run.align_checks)
        return
    case = signal_case(signal, senses.config.balance_ratio)
    ctx.emit("dock.signal", case=case, left=signal.front_left, right=signal.front_right)
    await ctx.trigger(case, left=signal.front_left, right=signal.front_right)


async def _adjust(ctx: RobotContext, senses: DockSenses, sign: float) -> None:
    """A micro turn the seed's way (the pair is crossed: the stronger side's opposite); a turn
    back the other way halves the step, so the compare closes in on L ~ R."""
    run = senses.run
    if run.adjust_sign and sign != run.adjust_sign:
        # Halved, but never below what a turn can do (``moves.TURN_TOLERANCE_RAD``): a
        # smaller step would not turn the robot at all and the compare would read the same
        # again until MAX_COMPARES.
        run.adjust_rad = max(MIN_ADJUST_RAD, run.adjust_rad / 2)
    run.adjust_sign = sign
    await senses.mover.turn_by(sign * run.adjust_rad)
    await ctx.trigger(DockTrigger.ADJUSTED,
                      turned_deg=round(math.degrees(sign * run.adjust_rad), 2))


async def balanced(ctx: RobotContext, senses: DockSenses) -> None:
    senses.run.dock_dir_rad = senses.mover.heading_rad  # the heading slow_forward holds
    await ctx.trigger(DockTrigger.ALIGNED)


async def _go(ctx: RobotContext, senses: DockSenses, trigger: str) -> None:
    await ctx.trigger(trigger)


def _align_handlers() -> Handlers:
    return {
        DockState.CENTER_BEAM_SEARCH: center_beam_search,
        DockState.FINE_ALIGN: fine_align,
        DockState.SIGNAL_COMPARE: signal_compare,
        DockState.LEFT_STRONGER: lambda c, s: _go(c, s, DockTrigger.ADJUST),
        DockState.RIGHT_STRONGER: lambda c, s: _go(c, s, DockTrigger.ADJUST),
        DockState.MICRO_ADJUST_R: lambda c, s: _adjust(c, s, -1.0),
        DockState.MICRO_ADJUST_L: lambda c, s: _adjust(c, s, 1.0),
        DockState.BALANCED: balanced,
    }


ALIGN_LOOP = PhaseLoop(DockState.ALIGN, _align_handlers())


async def run_align(ctx: RobotContext, senses: DockSenses) -> None:
    """The ``docking.align`` state's task (phase 3)."""
    await ALIGN_LOOP.run(ctx, senses)
