"""Cleaning: a coverage pattern that bounces on bumps and follows walls.

Straight runs; a bump backs off a little and turns away by a random angle (100-200 deg,
left); a wall met on the right (the side wall sensor) is followed for
``vacuum.wall_follow_s``, then the robot bounces on. The random turns come from a generator
the profile seeds, so a simulated run is repeatable.
"""

from __future__ import annotations

import asyncio
import math
import random
from typing import TYPE_CHECKING

from behaviours.motion.moves import Mover
from hal.devices import BumperSensor, WallSensor

if TYPE_CHECKING:
    from behaviours.context import RobotContext

PERIOD_S = 0.05
BACK_OFF_M = 0.06
WALL_TARGET_CM = 6.0
WALL_SEEN_CM = 15.0
WALL_LOST_CM = 30.0
WALL_GAIN = 0.05


class Coverage:
    """The cleaning pattern; ``run`` drives until cancelled."""

    def __init__(self, mover: Mover, bumpers: BumperSensor | None, wall: WallSensor | None,
                 rng: random.Random) -> None:
        self.mover = mover
        self.bumpers = bumpers
        self.wall = wall
        self.rng = rng
        self.bounces = 0
        self.wall_follows = 0

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
