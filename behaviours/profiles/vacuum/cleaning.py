"""Cleaning: a coverage pattern that bounces on bumps and follows walls, and keeps out of
virtual walls.

Straight runs; a bump backs off a little and turns away by a random angle (100-200 deg,
left); a wall met on the right (the side wall sensor) is followed for
``vacuum.wall_follow_s``, then the robot bounces on. A virtual wall (the OI's beam, code 162,
``docking.ir_codes.virtual_wall``) seen by any dock IR receiver is turned away from like a
bump, before the robot has crossed it (the seed's rear receiver's "Virtual Wall"): ahead (the
omni or a front receiver) 100-200 deg round, beside (one side receiver) 60-120 deg the other
way; seen only behind (the rear receiver) the robot is leaving it and drives on. The random
turns come from a generator the profile seeds, so a simulated run is repeatable.
"""

from __future__ import annotations

import asyncio
import math
import random
from typing import TYPE_CHECKING

from behaviours.docking.reverse import VIRTUAL_WALL
from behaviours.motion.moves import Mover
from hal.devices import BumperSensor, DockIr, WallSensor

if TYPE_CHECKING:
    from behaviours.context import RobotContext

PERIOD_S = 0.05
BACK_OFF_M = 0.06
WALL_TARGET_CM = 6.0
WALL_SEEN_CM = 15.0
WALL_LOST_CM = 30.0
WALL_GAIN = 0.05
LEAVE_BEAM_M = 0.5
"""After turning away from a virtual wall the robot leaves its beam; still in it this much
later, it turns away again."""


class Coverage:
    """The cleaning pattern; ``run`` drives until cancelled."""

    def __init__(self, mover: Mover, bumpers: BumperSensor | None, wall: WallSensor | None,
                 rng: random.Random, dock_ir: DockIr | None = None) -> None:
        self.mover = mover
        self.bumpers = bumpers
        self.wall = wall
        self.rng = rng
        self.dock_ir = dock_ir
        self.bounces = 0
        self.wall_follows = 0
        self.virtual_walls = 0
        self._turned_at: tuple[float, float] | None = None

    def _virtual_wall(self) -> frozenset[str]:
        """The receivers that see a virtual wall now (none without dock IR receivers)."""
        reading = None if self.dock_ir is None else self.dock_ir.latest()
        if reading is None:
            return frozenset()
        return frozenset(r for r, beams in reading.beams.items() if VIRTUAL_WALL in beams)

    def _heed_virtual_wall(self, seen: frozenset[str]) -> bool:
        """Whether the beam seen now calls for a turn (not just behind, not the beam the robot
        is leaving after a turn)."""
        if not seen:
            self._turned_at = None
            return False
        if seen == {"rear"}:
            return False
        if self._turned_at is None:
            return True
        return math.dist(self._turned_at, self.mover.position()) > LEAVE_BEAM_M

    def _bumped(self) -> bool:
        reading = None if self.bumpers is None else self.bumpers.latest()
        return reading is not None and reading.any

    def _wall_cm(self) -> float | None:
        reading = None if self.wall is None else self.wall.latest()
        return None if reading is None else reading.distance_cm

    async def run(self, ctx: RobotContext) -> None:
        speed = float(ctx.settings.get("vacuum.clean_mps"))
        loop = asyncio.get_running_loop()
        following_until = 0.0
        try:
            while True:
                if self._bumped():
                    await self.bounce(ctx)
                    continue
                seen = self._virtual_wall()
                if self._heed_virtual_wall(seen):
                    await self.turn_away(ctx, seen)
                    continue
                wall = self._wall_cm()
                now = loop.time()
                omega = 0.0
                if wall is not None and wall < WALL_SEEN_CM and following_until <= now:
                    following_until = now + float(ctx.settings.get("vacuum.wall_follow_s"))
                    self.wall_follows += 1
                    ctx.emit("clean.wall_follow", wall_cm=round(wall, 1))
                if following_until > now and wall is not None and wall < WALL_LOST_CM:
                    omega = max(-0.8, min(0.8, -WALL_GAIN * (wall - WALL_TARGET_CM)))
                elif following_until > now:
                    omega = -0.6  # round the corner the wall turned
                await self.mover.send(speed, omega)
                await asyncio.sleep(PERIOD_S)
        finally:
            await asyncio.shield(self.mover.stop())

    async def bounce(self, ctx: RobotContext) -> None:
        self.bounces += 1
        await self.mover.straight(BACK_OFF_M, -0.1)
        angle = math.radians(self.rng.uniform(100, 200))
        ctx.emit("clean.bounce", turn_deg=round(math.degrees(angle)))
        await self.mover.turn_by(angle)

    async def turn_away(self, ctx: RobotContext, seen: frozenset[str]) -> None:
        """A virtual wall seen: stop and turn away from it (see the module's docstring)."""
        self.virtual_walls += 1
        await self.mover.send(0.0, 0.0)
        ahead = bool(seen & {"omni", "front_left", "front_right"})
        if ahead or seen >= {"side_left", "side_right"}:
            angle = math.radians(self.rng.uniform(100, 200))
        else:
            sign = -1.0 if "side_left" in seen else 1.0
            angle = sign * math.radians(self.rng.uniform(60, 120))
        ctx.emit("clean.virtual_wall", receivers=sorted(seen), turn_deg=round(math.degrees(angle)))
        await self.mover.turn_by(angle)
        self._turned_at = self.mover.position()
