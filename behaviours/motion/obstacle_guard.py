"""A safety layer over the wheels: no forward motion while something is close ahead.

``ObstacleGuard`` is a ``Motors`` that passes commands through to the real one, except that a
command with forward motion becomes a stop while the front range sensor reads less than
``safety.stop_distance_cm`` (until it reads more than ``safety.resume_distance_cm``), or when
its newest reading is too old to trust. Turning in place and reversing pass, so a behaviour can
still back away. Any behaviour that drives can be given the guard instead of the motors.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from typing import Any

import structlog

from hal.devices import Motors, RangeSensor
from hal.readings import LinkStats, MotorCommand
from hal.settings import SettingsView

log = structlog.get_logger(__name__)


class MotorsPassThrough:
    """A ``Motors`` that hands everything to the one it wraps; layers over the wheels (the
    obstacle guard, the encoder watch's record of commands) override what they change."""

    def __init__(self, motors: Motors) -> None:
        self.motors = motors
        self.name = getattr(motors, "name", "motors")

    @property
    def connected(self) -> bool:
        return self.motors.connected

    async def start(self) -> None:
        await self.motors.start()

    async def close(self) -> None:
        await self.motors.close()

    def status(self) -> dict[str, Any]:
        return self.motors.status()

    def on_link_change(self, callback: Callable[[bool], None]) -> None:
        self.motors.on_link_change(callback)

    def link_stats(self) -> LinkStats:
        return self.motors.link_stats()

    async def stop(self) -> None:
        await self.motors.stop()

    async def drive(self, command: MotorCommand) -> None:
        await self.motors.drive(command)


class ObstacleGuard(MotorsPassThrough):
    def __init__(self, motors: Motors, front_range: RangeSensor, settings: SettingsView,
                 emit: Callable[..., None] | None = None) -> None:
        super().__init__(motors)
        self.front_range = front_range
        self.settings = settings
        self.name = f"{getattr(motors, 'name', 'motors')}+guard"
        self.blocked = False
        self.blocked_since_s: float | None = None
        """Loop time the current block began (None: not blocked)."""
        self.blocked_why = ""
        self.blocks = 0
        self._emit = emit

    def status(self) -> dict[str, Any]:
        return {**self.motors.status(), "guard_blocked": self.blocked,
                "guard_blocks": self.blocks}

    async def drive(self, command: MotorCommand) -> None:
        if _moves_forward(command) and self._path_blocked():
            await self.motors.drive(MotorCommand.stopped())
            return
        await self.motors.drive(command)

    # --------------------------------------------------------------------------------------
    def _path_blocked(self) -> bool:
        reading = self.front_range.latest()
        s = self.settings
        now = asyncio.get_running_loop().time()
        if reading is None or now - reading.t_s > s.get("safety.max_reading_age_s"):
            self._set(True, None, "no recent front reading")
            return True
        limit = s.get("safety.resume_distance_cm") if self.blocked else \
            s.get("safety.stop_distance_cm")
        self._set(reading.distance_cm < limit, reading.distance_cm, "obstacle ahead")
        return self.blocked

    def _set(self, blocked: bool, distance_cm: float | None, why: str) -> None:
        if blocked == self.blocked:
            return
        self.blocked = blocked
        self.blocked_since_s = asyncio.get_running_loop().time() if blocked else None
        self.blocked_why = why if blocked else ""
        if blocked:
            self.blocks += 1
            log.info("guard.blocked", distance_cm=distance_cm, reason=why)
        else:
            log.info("guard.clear", distance_cm=distance_cm)
        if self._emit is not None:
            self._emit("guard.blocked" if blocked else "guard.clear", distance_cm=distance_cm,
                       reason=why if blocked else None)


def _moves_forward(command: MotorCommand) -> bool:
    left, right = command.signed()
    return left + right > 0
