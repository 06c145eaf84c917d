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
from behaviours.docking.senses import DockSenses, run_phase

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
        await ctx.trigger("signal_lost", reason=f"scan_beams: no case for {seen}")
        return
    senses.run.offset_rad = 0.0
    await ctx.trigger(case)


def _side(sign: float) -> dict[str, object]:
    """The handlers of a side approach; ``sign`` +1 turns left (from Far-R), -1 right."""
    near = "front_right" if sign > 0 else "front_left"

    async def turn(ctx: RobotContext, senses: DockSenses) -> None:
        # Far out (a weak signal) cross at half the angle: more of the way goes towards
        # the dock, and the far beam's 4 m range is not left on the way.
        far = senses.strength() < FAR_STRENGTH
        angle = math.radians(senses.config.side_turn_deg) * (0.5 if far else 1.0)
        senses.run.offset_rad = sign * angle
        await senses.mover.turn_by(sign * angle)
        await ctx.trigger("turned", turn_deg=round(math.degrees(sign * angle), 1), far=far)

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
            await ctx.trigger("signal_lost", reason=f"{near} beam not met in {driven:.2f} m")
            return
        await ctx.trigger("front_beam_entered", beam=near)

    async def entry(ctx: RobotContext, senses: DockSenses) -> None:
        await senses.mover.turn_by(-senses.run.offset_rad / 2)
        await ctx.trigger("turned")

    async def overlap(ctx: RobotContext, senses: DockSenses) -> None:
        view = senses.view
        await senses.mover.straight(
            OVERLAP_MAX_M, senses.config.approach_mps,
            until=lambda: front_case(view()) in ("front_both", _far(sign)) or senses.bumped())
        await face_dock(senses)
        await ctx.trigger("overlap_reached")

    return {"turn": turn, "forward": forward, "entry": entry, "overlap": overlap}


def _far(sign: float) -> str:
    """The front beam beyond the overlap, met when the crossing overshoots it."""
    return "front_left_only" if sign > 0 else "front_right_only"


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
    await ctx.trigger(case or "signal_lost", reason="check_skew: no front beam")


async def centered(ctx: RobotContext, senses: DockSenses) -> None:
    senses.run.offset_rad = 0.0
    await face_dock(senses)
    await ctx.trigger("overlap_reached")


async def turn180(ctx: RobotContext, senses: DockSenses) -> None:
    await senses.mover.turn_by(math.pi)
    await ctx.trigger("turned")


async def front_now(ctx: RobotContext, senses: DockSenses) -> None:
    await face_dock(senses)
    await ctx.trigger("front_ready")


async def _go(ctx: RobotContext, senses: DockSenses, trigger: str) -> None:
    await ctx.trigger(trigger)


def position_handlers() -> dict[str, object]:
    left, right = _side(1.0), _side(-1.0)
    return {
        "scan_beams": scan_beams,
        "left_approach.turn_left": left["turn"], "left_approach.forward_l": left["forward"],
        "left_approach.front_r_entry": left["entry"],
        "left_approach.overlap_l": left["overlap"],
        "right_approach.turn_right": right["turn"],
        "right_approach.forward_r": right["forward"],
        "right_approach.front_l_entry": right["entry"],
        "right_approach.overlap_r": right["overlap"],
        "front_approach.check_skew": check_skew,
        "front_approach.skew_left": lambda c, s: _go(c, s, "correct"),
        "front_approach.skew_right": lambda c, s: _go(c, s, "correct"),
        "front_approach.correct_right": lambda c, s: _micro_step(c, s, -1.0, "corrected"),
        "front_approach.correct_left": lambda c, s: _micro_step(c, s, 1.0, "corrected"),
        "front_approach.centered": centered,
        "rear_approach.turn180": turn180,
        "rear_approach.front_now": front_now,
    }


# -- phase 2 --------------------------------------------------------------------------------
async def front_beam_detect(ctx: RobotContext, senses: DockSenses) -> None:
    await asyncio.sleep(SETTLE_S)
    view = senses.view()
    case = front_case(view)
    if case is None and view.located("far_left"):
        case = "front_left_only"
    elif case is None and view.located("far_right"):
        case = "front_right_only"
    if case is not None:
        await ctx.trigger(case)
    elif await face_dock(senses) is None:
        await ctx.trigger("signal_lost", reason="front_beam_detect: the dock is out of sight")


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
    await ctx.trigger("approached", closed_in_m=round(driven, 3), strength=senses.strength())


def approach_handlers() -> dict[str, object]:
    return {
        "front_beam_detect": front_beam_detect,
        "left_only": lambda c, s: _go(c, s, "micro_turn"),
        "right_only": lambda c, s: _go(c, s, "micro_turn"),
        "micro_right": lambda c, s: _micro_step(c, s, -1.0, "turned"),
        "micro_left": lambda c, s: _micro_step(c, s, 1.0, "turned"),
        "both_beams": lambda c, s: _go(c, s, "in_overlap"),
        "overlap_zone": overlap_zone,
    }


async def run_position(ctx: RobotContext, senses: DockSenses) -> None:
    """The ``docking.position`` state's task (section 2)."""
    await run_phase(ctx, senses, "docking.position", position_handlers())


async def run_approach(ctx: RobotContext, senses: DockSenses) -> None:
    """The ``docking.approach`` state's task (phase 2)."""
    await run_phase(ctx, senses, "docking.approach", approach_handlers())
