"""Section 2's position cases and phase 2, approach: from wherever the beams say the robot is
to the overlap of the two front beams, facing the dock.

``scan_beams`` picks the case (``beams.position_case``). A side approach turns across the
beams (left from Far-R, right from Far-L), drives until it meets the near front beam, turns
halfway back and drives on into the overlap. The rear case turns round (rear docking is
refused) and goes on as the front case. The front case and phase 2 are the same loop: in one
front beam only, turn a micro angle towards the other (each a transition) and drive a step;
in both, face the dock and close in until the centre beam is seen.
"""

from __future__ import annotations

import asyncio
import math
from typing import TYPE_CHECKING

from behaviours.docking.beams import front_case, position_case, skew_case
from behaviours.docking.search import face_dock
from behaviours.docking.senses import DockSenses, Handlers, PhaseLoop, PhaseStep
from behaviours.docking.tables import DockState, DockTrigger

if TYPE_CHECKING:
    from behaviours.context import RobotContext

SETTLE_S = 0.25  # a beam cycle (144 ms) into the decoder's window after a move
STEP_M = 0.5
FORWARD_MAX_M = 4.0
OVERLAP_MAX_M = 2.0
CLOSE_IN_MAX_M = 3.0
MAX_OFFSET_RAD = math.radians(50)
MAX_BUMPS = 3
FAR_STRENGTH = 30
"""Front strength below this: the dock is farther than about 2.5 m (a sim-calibrated
figure; the inverse-square fall-off makes it a coarse range)."""
BUMP_BACK_M = 0.08
BUMP_TURN_RAD = math.radians(30)


# -- section 2 ------------------------------------------------------------------------------
async def scan_beams(ctx: RobotContext, senses: DockSenses) -> None:
    await asyncio.sleep(SETTLE_S)
    view = senses.view()
    case = position_case(view)
    if case is None:
        seen = {r: sorted(b) for r, b in view.reading.beams.items() if b}
        await ctx.trigger(DockTrigger.SIGNAL_LOST, reason=f"scan_beams: no case for {seen}")
        return
    senses.run.offset_rad = 0.0
    await ctx.trigger(case)


def _side(sign: float) -> dict[str, PhaseStep]:
    """The handlers of a side approach; ``sign`` +1 turns left (from Far-R), -1 right."""
    near = "front_right" if sign > 0 else "front_left"

    async def turn(ctx: RobotContext, senses: DockSenses) -> None:
        # Far out (a weak signal) cross at half the angle: more of the way goes towards
        # the dock, and the far beam's 4 m range is not left on the way.
        far = senses.strength() < FAR_STRENGTH
        angle = math.radians(senses.config.side_turn_deg) * (0.5 if far else 1.0)
        senses.run.offset_rad = sign * angle
        await senses.mover.turn_by(sign * angle)
        await ctx.trigger(DockTrigger.TURNED, turn_deg=round(math.degrees(sign * angle), 1),
                          far=far)

    async def forward(ctx: RobotContext, senses: DockSenses) -> None:
        view, mover = senses.view, senses.mover
        driven = 0.0
        for _ in range(MAX_BUMPS):
            driven += await mover.straight(
                FORWARD_MAX_M - driven, senses.config.approach_mps,
                until=lambda: front_case(view()) is not None or senses.bumped())
            if not senses.bumped():
                break
            # Something in the way: back off and cross more steeply towards the dock.
            await mover.straight(BUMP_BACK_M, -senses.config.approach_mps)
            await mover.turn_by(-sign * BUMP_TURN_RAD)
        if front_case(view()) is None:
            await ctx.trigger(DockTrigger.SIGNAL_LOST,
                              reason=f"{near} beam not met in {driven:.2f} m")
            return
        await ctx.trigger(DockTrigger.FRONT_BEAM_ENTERED, beam=near)

    async def entry(ctx: RobotContext, senses: DockSenses) -> None:
        await senses.mover.turn_by(-senses.run.offset_rad / 2)
        await ctx.trigger(DockTrigger.TURNED)

    async def overlap(ctx: RobotContext, senses: DockSenses) -> None:
        view = senses.view
        await senses.mover.straight(
            OVERLAP_MAX_M, senses.config.approach_mps,
            until=lambda: front_case(view()) in (DockTrigger.FRONT_BOTH, _far(sign))
            or senses.bumped())
        await face_dock(senses)
        await ctx.trigger(DockTrigger.OVERLAP_REACHED)

    return {"turn": turn, "forward": forward, "entry": entry, "overlap": overlap}


def _far(sign: float) -> str:
    """The front beam beyond the overlap, met when the crossing overshoots it."""
    return DockTrigger.FRONT_LEFT_ONLY if sign > 0 else DockTrigger.FRONT_RIGHT_ONLY


async def _micro_step(ctx: RobotContext, senses: DockSenses, sign: float, trigger: str) -> None:
    """Turn a micro angle towards the far side of the overlap (``sign`` +1: left) and drive
    on until the beams change (at most a step); each turn adds to the ones before.

    Only a far beam seen (after turning from the rear): the side-approach angle at once."""
    cfg, view = senses.config, senses.view
    before = front_case(view())
    if before is None:
        angle = sign * math.radians(cfg.side_turn_deg)
        step = FORWARD_MAX_M
    else:
        angle = sign * math.radians(cfg.micro_turn_deg)
        step = STEP_M
    senses.run.offset_rad += angle
    await senses.mover.turn_by(angle)
    await senses.mover.straight(step, cfg.approach_mps,
                                until=lambda: front_case(view()) != before or senses.bumped())
    await ctx.trigger(trigger, offset_deg=round(math.degrees(senses.run.offset_rad), 1))


async def check_skew(ctx: RobotContext, senses: DockSenses) -> None:
    await asyncio.sleep(SETTLE_S)
    case = skew_case(senses.view())
    await ctx.trigger(case or DockTrigger.SIGNAL_LOST, reason="check_skew: no front beam")


async def centered(ctx: RobotContext, senses: DockSenses) -> None:
    senses.run.offset_rad = 0.0
    await face_dock(senses)
    await ctx.trigger(DockTrigger.OVERLAP_REACHED)


async def turn180(ctx: RobotContext, senses: DockSenses) -> None:
    await senses.mover.turn_by(math.pi)
    await ctx.trigger(DockTrigger.TURNED)


async def front_now(ctx: RobotContext, senses: DockSenses) -> None:
    await face_dock(senses)
    await ctx.trigger(DockTrigger.FRONT_READY)


async def _go(ctx: RobotContext, senses: DockSenses, trigger: str) -> None:
    await ctx.trigger(trigger)


def _position_handlers() -> Handlers:
    left, right = _side(1.0), _side(-1.0)
    return {
        DockState.SCAN_BEAMS: scan_beams,
        DockState.TURN_LEFT: left["turn"], DockState.FORWARD_L: left["forward"],
        DockState.FRONT_R_ENTRY: left["entry"], DockState.OVERLAP_L: left["overlap"],
        DockState.TURN_RIGHT: right["turn"], DockState.FORWARD_R: right["forward"],
        DockState.FRONT_L_ENTRY: right["entry"], DockState.OVERLAP_R: right["overlap"],
        DockState.CHECK_SKEW: check_skew,
        DockState.SKEW_LEFT: lambda c, s: _go(c, s, DockTrigger.CORRECT),
        DockState.SKEW_RIGHT: lambda c, s: _go(c, s, DockTrigger.CORRECT),
        DockState.CORRECT_RIGHT: lambda c, s: _micro_step(c, s, -1.0, DockTrigger.CORRECTED),
        DockState.CORRECT_LEFT: lambda c, s: _micro_step(c, s, 1.0, DockTrigger.CORRECTED),
        DockState.CENTERED: centered,
        DockState.TURN180: turn180,
        DockState.FRONT_NOW: front_now,
    }


POSITION_LOOP = PhaseLoop(DockState.POSITION, _position_handlers())


# -- phase 2 --------------------------------------------------------------------------------
async def front_beam_detect(ctx: RobotContext, senses: DockSenses) -> None:
    await asyncio.sleep(SETTLE_S)
    view = senses.view()
    case = front_case(view)
    if case is None and view.located("far_left"):
        case = DockTrigger.FRONT_LEFT_ONLY
    elif case is None and view.located("far_right"):
        case = DockTrigger.FRONT_RIGHT_ONLY
    if case is not None:
        await ctx.trigger(case)
    elif await face_dock(senses) is None:
        await ctx.trigger(DockTrigger.SIGNAL_LOST,
                          reason="front_beam_detect: the dock is out of sight")


async def overlap_zone(ctx: RobotContext, senses: DockSenses) -> None:
    """Face the dock and close in until the front pair reads ``docking.align_strength`` (the
    centre beam's last metre, the pair not yet saturated)."""
    senses.run.offset_rad = 0.0
    view = senses.view
    run = senses.run
    if run.scanned_at is None or math.dist(run.scanned_at, senses.mover.position()) > 0.1:
        await face_dock(senses)
    heading = senses.dock_dir()
    near = senses.config.align_strength
    driven = await senses.mover.straight(
        CLOSE_IN_MAX_M, senses.config.approach_mps, heading_rad=heading,
        until=lambda: senses.strength() >= near or view().located("force_field")
        or senses.bumped())
    await ctx.trigger(DockTrigger.APPROACHED, closed_in_m=round(driven, 3),
                      strength=senses.strength())


def _approach_handlers() -> Handlers:
    return {
        DockState.FRONT_BEAM_DETECT: front_beam_detect,
        DockState.LEFT_ONLY: lambda c, s: _go(c, s, DockTrigger.MICRO_TURN),
        DockState.RIGHT_ONLY: lambda c, s: _go(c, s, DockTrigger.MICRO_TURN),
        DockState.MICRO_RIGHT: lambda c, s: _micro_step(c, s, -1.0, DockTrigger.TURNED),
        DockState.MICRO_LEFT: lambda c, s: _micro_step(c, s, 1.0, DockTrigger.TURNED),
        DockState.BOTH_BEAMS: lambda c, s: _go(c, s, DockTrigger.IN_OVERLAP),
        DockState.OVERLAP_ZONE: overlap_zone,
    }


APPROACH_LOOP = PhaseLoop(DockState.APPROACH, _approach_handlers())


async def run_position(ctx: RobotContext, senses: DockSenses) -> None:
    """The ``docking.position`` state's task (section 2)."""
    await POSITION_LOOP.run(ctx, senses)


async def run_approach(ctx: RobotContext, senses: DockSenses) -> None:
    """The ``docking.approach`` state's task (phase 2)."""
    await APPROACH_LOOP.run(ctx, senses)
