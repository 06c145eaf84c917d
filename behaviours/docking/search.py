"""Phase 1, search: follow the walls until a dock beam is seen, make sure of it, turn to it.

``wall_follow`` keeps the right-side wall sensor near ``WALL_TARGET_CM`` and turns left off a
bump; after ``WALL_LEG_S`` along one wall it turns away and crosses the room; it ends as soon
as any receiver sees one of the dock's beams (``beam_detected``).
``force_field_detect`` stops and watches a little. The seed's "Force Field 감지" is the
dock's force field (its short-range, all-round beam, OI code 161: ``beam_roles.force_field``),
not just any beam: seen, it is ``field_detected``; a far or front beam without it leads the
robot in (``home_in``: it turns to the dock, round first when only its rear receiver sees it,
and closes in, a leg of up to 3 m and a fresh scan after a bump, until the force field is
seen; it never backs up towards the dock, which would be blind for metres); no beam any more
is ``field_lost`` (back to the walls). ``direction_turn`` turns to the dock, found by a turn
each way across the arc where the crossed front pair sees it (``scan_dock_dir``), and backs
out of the force field to a stand-off (``stand_off``: section 2's cases need room), or leaves
a robot whose rear receiver alone sees it facing away: that is section 2's rear case.
"""

from __future__ import annotations

import asyncio
import math
from collections.abc import Callable
from typing import TYPE_CHECKING

import structlog

from behaviours.docking.beams import FRONT_RECEIVERS, BeamView
from behaviours.docking.reverse import back_up
from behaviours.docking.senses import DockSenses, PhaseLoop
from behaviours.docking.tables import DockState, DockTrigger
from behaviours.motion.moves import wrap

if TYPE_CHECKING:
    from behaviours.context import RobotContext

log = structlog.get_logger(__name__)

WALL_TARGET_CM = 8.0
WALL_RANGE_CM = 30.0
WALL_GAIN = 0.04  # rad/s per cm of wall-distance error
BUMP_BACK_M = 0.05
BUMP_TURN_RAD = math.radians(50)
WALL_LEG_S = 30.0
"""Along one wall this long: leave it (an island would be circled for ever); long enough to
follow the side of a long room (30 s: 7.5 m)."""
SETTLE_AFTER_BUMP_S = 0.6
MAX_TOWARDS_WALL_RPS = 0.4
LEAVE_TURN_RAD = math.radians(150)
CONFIRM_S = 0.4
MOVE_ON_M = 0.8
SCAN_DPS = 90.0
FINE_DPS = 20.0
FINE_START_DEG = 40.0
PERIOD_S = 0.05
HOME_LEG_M = 3.0
HOME_LEGS = 4
HOME_MAX_M = 3.0
BEAM_GONE_S = 0.6
STAND_OFF_M = 0.3
STAND_OFF_MAX_M = 1.2
RESCAN_M = 1.2
"""A direction found this close by still holds (the dock is a metre or more away)."""


async def wall_follow(ctx: RobotContext, senses: DockSenses) -> None:
    mover, cfg, run = senses.mover, senses.config, senses.run
    start = mover.position()

    def heed() -> bool:
        moved = math.dist(start, mover.position())
        return moved >= run.moved_for_search_m and senses.view().dock_seen()

    loop = asyncio.get_running_loop()
    following_since: float | None = None
    straight_until = 0.0
    while not heed():
        if senses.bumped():
            await back_up(ctx, senses, BUMP_BACK_M, cfg.search_mps, why="wall_follow")
            await mover.turn_by(BUMP_TURN_RAD)
            # Drive on straight a moment: steering back to the wall at once would put the
            # nose into the corner just turned from (a robot stuck in a corner for ever).
            straight_until = loop.time() + SETTLE_AFTER_BUMP_S
            continue
        wall = senses.wall_cm()
        omega = 0.0
        if loop.time() < straight_until:
            pass
        elif wall is not None and wall < WALL_RANGE_CM:
            now = loop.time()
            following_since = now if following_since is None else following_since
            if now - following_since > WALL_LEG_S:
                # Long enough along this wall: cross the room (a wall the beams do not
                # reach, or an island, would keep the robot going round for ever).
                await mover.turn_by(LEAVE_TURN_RAD)
                following_since = None
                continue
            omega = -WALL_GAIN * (wall - WALL_TARGET_CM)
        await mover.send(cfg.search_mps, max(-MAX_TOWARDS_WALL_RPS, min(0.8, omega)))
        await asyncio.sleep(PERIOD_S)
    await mover.send(0.0, 0.0)
    run.moved_for_search_m = 0.0
    await ctx.trigger(DockTrigger.BEAM_DETECTED)


async def force_field_detect(ctx: RobotContext, senses: DockSenses) -> None:
    await senses.mover.stop()
    await asyncio.sleep(CONFIRM_S)
    view = senses.view()
    homed = None
    if view.dock_seen() and not view.field_seen():
        homed = await home_in(ctx, senses)
        view = senses.view()
    if view.field_seen():
        ctx.emit("dock.field", beams={r: sorted(b) for r, b in view.reading.beams.items()
                                      if b}, homed=homed)
        await ctx.trigger(DockTrigger.FIELD_DETECTED)
        return
    senses.run.moved_for_search_m = MOVE_ON_M
    await ctx.trigger(DockTrigger.FIELD_LOST, homed=homed,
                      reason="no force field" if view.dock_seen() else "no dock beam")


def _rear_only(view: BeamView) -> bool:
    return view.sees_any("rear") and not view.front_sees() and not view.field_seen()


async def home_in(ctx: RobotContext, senses: DockSenses) -> str | None:
    """Towards the dock until its force field is seen, on the front pair's direction (a leg
    of ``HOME_LEG_M`` at a time; a bump turns the robot off the obstacle), turned round first
    when only the rear receiver sees the dock; how it went (``forward``, ``turned``), None
    when it found no way in."""
    mover, cfg = senses.mover, senses.config
    loop = asyncio.get_running_loop()
    last_seen = loop.time()

    def arrived() -> bool:
        # The force field, or the dock gone for good (a frame or two missing is not gone).
        nonlocal last_seen
        view = senses.view()
        if view.dock_seen():
            last_seen = loop.time()
        return view.field_seen() or loop.time() - last_seen > BEAM_GONE_S

    way = "forward"
    if _rear_only(senses.view()):
        # Facing away: turn round first (backing up to it would be blind for metres).
        await mover.turn_by(math.pi)
        way = "turned"
    for _ in range(HOME_LEGS):
        if arrived():
            break
        direction = await face_dock(senses)
        if direction is None:
            return None
        await mover.straight(HOME_LEG_M, cfg.approach_mps, heading_rad=direction,
                             until=lambda: arrived() or senses.bumped())
        if senses.bumped():
            await back_up(ctx, senses, BUMP_BACK_M, cfg.search_mps, why="home_in")
            await mover.turn_by(BUMP_TURN_RAD)
            await mover.straight(HOME_LEG_M / 2, cfg.approach_mps,
                                 until=lambda: arrived() or senses.bumped())
    ctx.emit("dock.home_in", way=way, field=senses.view().field_seen())
    return way


async def direction_turn(ctx: RobotContext, senses: DockSenses) -> None:
    view = senses.view()
    if view.sees_any("rear") and not view.front_sees():
        await ctx.trigger(DockTrigger.DIRECTION_FOUND, towards="rear")
        return
    run = senses.run
    if run.scanned_at is not None and run.dock_dir_rad is not None \
            and math.dist(run.scanned_at, senses.mover.position()) < RESCAN_M \
            and _both_front(view):
        # Just found on the way in (home_in): face it again rather than scan again.
        await senses.mover.turn_to(run.dock_dir_rad)
    elif await face_dock(senses) is None:
        senses.run.moved_for_search_m = MOVE_ON_M
        await ctx.trigger(DockTrigger.FIELD_LOST)
        return
    stood_off = await stand_off(ctx, senses)
    await ctx.trigger(DockTrigger.DIRECTION_FOUND, towards="front", stood_off_m=stood_off)


async def stand_off(ctx: RobotContext, senses: DockSenses) -> float:
    """Facing the dock inside its force field: back away from it (reverse guard) until the
    field is left and ``STAND_OFF_M`` more, so that section 2's cases start where the beams
    tell them apart (next to the dock, by a wall, they do not); the distance backed."""
    cfg = senses.config
    if not senses.view().located("force_field"):
        return 0.0
    loop = asyncio.get_running_loop()
    left_at: list[tuple[float, float]] = []

    def far_enough() -> bool:
        if senses.view().located("force_field"):
            left_at.clear()
            return False
        if not left_at:
            left_at.append(senses.mover.position())
        return math.dist(left_at[0], senses.mover.position()) >= STAND_OFF_M

    start = loop.time()
    backed = await back_up(ctx, senses, STAND_OFF_MAX_M, cfg.approach_mps, why="stand_off",
                           until=far_enough)
    ctx.emit("dock.stand_off", backed_m=round(backed, 3),
             time_s=round(loop.time() - start, 2))
    return round(backed, 3)


def _both_front(view: BeamView) -> bool:
    return all(view.sees_any(r) for r in FRONT_RECEIVERS)


def _either_front(view: BeamView) -> bool:
    return view.front_sees()


async def scan_dock_dir(senses: DockSenses, *, dps: float = SCAN_DPS,
                        around: float | None = None) -> float | None:
    """The dock's direction (odometry frame) from a turn each way across it.

    The front pair is crossed, so both see the dock over an arc centred on it (+-25 deg);
    turning left then right over that arc, each pass's middle is off by the decoder's delay
    the way it turned, and the mean of the two is the dock's direction. None when neither
    front receiver sees the dock in a whole turn. ``around``: where the dock is thought to be
    (the passes then start just right of it and sweep only the arc round it), turning at
    ``dps``."""
    first_limit = 2 * math.pi
    if around is not None:
        await senses.mover.turn_to(around - math.radians(FINE_START_DEG))
        first_limit = math.radians(3 * FINE_START_DEG)
    for seen in (_both_front, _either_front):
        first = _first_way(senses.view()) if around is None else 1.0
        if seen(senses.view()):
            # Inside the arc: leave it to the left, then cross it rightwards and back.
            await _pass(senses, 1.0, math.pi, _negate(seen), dps)
            first = -1.0
        middles: list[float] = []
        for sign, limit in ((first, first_limit), (-first, math.pi)):
            middle = await _pass(senses, sign, limit, seen, dps)
            if middle is None:
                break
            middles.append(middle)
        if len(middles) == 2:
            a, b = middles
            direction = wrap(a + wrap(b - a) / 2)
            senses.run.dock_dir_rad = direction
            senses.run.scanned_at = senses.mover.position()
            return direction
    return None


def _first_way(view: BeamView) -> float:
    """Which way to turn first looking for the dock: towards the side receiver that sees it
    (-1: right), left when both or neither do (a real robot does not turn the long way)."""
    if view.sees_any("side_right") and not view.sees_any("side_left"):
        return -1.0
    return 1.0


def _negate(seen: Callable[[BeamView], bool]) -> Callable[[BeamView], bool]:
    return lambda view: not seen(view)


async def _pass(senses: DockSenses, sign: float, limit_rad: float,
                seen: Callable[[BeamView], bool], dps: float) -> float | None:
    """Turn until the arc where ``seen`` holds has been crossed; its middle, or None."""
    mover = senses.mover
    rate = math.radians(dps)
    last = mover.heading_rad
    turned = 0.0
    entered: float | None = None
    outside = not seen(senses.view())  # a pass measures an arc from its start only
    result = None
    while turned < limit_rad:
        await mover.send(0.0, sign * rate)
        await asyncio.sleep(PERIOD_S)
        heading = mover.heading_rad
        turned += abs(wrap(heading - last))
        last = heading
        inside = seen(senses.view())
        if not inside and not outside:
            outside = True
        elif inside and outside and entered is None:
            entered = heading
        elif not inside and entered is not None:
            result = wrap(entered + wrap(heading - entered) / 2)
            break
    await mover.send(0.0, 0.0)
    return result


async def face_dock(senses: DockSenses) -> float | None:
    """Scan for the dock's direction and turn to it; the direction, or None."""
    direction = await scan_dock_dir(senses)
    if direction is not None:
        await senses.mover.turn_to(direction)
    return direction


SEARCH_LOOP = PhaseLoop(DockState.SEARCH, {
    DockState.WALL_FOLLOW: wall_follow,
    DockState.FORCE_FIELD_DETECT: force_field_detect,
    DockState.DIRECTION_TURN: direction_turn,
})


async def run_search(ctx: RobotContext, senses: DockSenses) -> None:
    """The ``docking.search`` state's task; next to the dock (after a fallback), it wall
    follows away first: the beams there say little about where to come in from."""
    if senses.view().located("force_field") or senses.contact_mv() > 0:
        # At the dock (a fallback after failed contacts): back out and turn round first;
        # pushing on would only spin the wheels against the pads.
        await back_up(ctx, senses, senses.config.undock_distance_m,
                      senses.config.approach_mps, why="search")
        await senses.mover.turn_by(math.pi)
        senses.run.moved_for_search_m = MOVE_ON_M
    await SEARCH_LOOP.run(ctx, senses)
