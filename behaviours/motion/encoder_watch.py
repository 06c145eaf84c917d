"""Encoder failure (the seed's error table): the wheels are driven but the ticks stand still.

``CommandedMotors`` is a ``Motors`` that passes everything through and remembers the last
command that reached the board (put it under the obstacle guard, so a command the guard turned
into a stop counts as a stop). ``EncoderWatch`` polls the encoders' newest reading: when the
wheels have been commanded above ``min_pwm`` (with the link up) for longer than ``freeze_s``
and the tick counts have not changed in that time (frozen counters, or no ``ENCODER`` telemetry
at all), the encoders have failed; the first change of the counts after that is their return.
Each change is handed to ``on_change(failed, figures)`` once.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import structlog

from behaviours.motion.obstacle_guard import MotorsPassThrough
from hal.devices import Encoders, Motors
from hal.readings import MotorCommand

log = structlog.get_logger(__name__)


class CommandedMotors(MotorsPassThrough):
    """The wheels, passed through; ``last`` is the command the board was given last."""

    def __init__(self, motors: Motors) -> None:
        super().__init__(motors)
        self.last = MotorCommand.stopped()

    async def stop(self) -> None:
        self.last = MotorCommand.stopped()
        await self.motors.stop()

    async def drive(self, command: MotorCommand) -> None:
        self.last = command
        await self.motors.drive(command)

    def commanded_pwm(self) -> int:
        """The larger wheel PWM of the last command; 0 while the link is down (the board's
        deadman has stopped the wheels)."""
        if not self.motors.connected:
            return 0
        return max(self.last.left_pwm, self.last.right_pwm)


@dataclass(frozen=True, slots=True)
class EncoderWatchConfig:
    freeze_s: float = 0.5
    """Driven this long with no tick change: the encoders have failed."""
    min_pwm: int = 40
    """Commands at or above this PWM turn the wheels (past the deadband, with a margin)."""
    period_s: float = 0.1


class EncoderWatch:
    """Tells ``on_change`` when the encoders stop following the commanded wheels, and when
    they come back."""

    def __init__(self, encoders: Encoders, commanded_pwm: Callable[[], int],
                 on_change: Callable[[bool, dict[str, Any]], None],
                 config: EncoderWatchConfig | None = None) -> None:
        self.encoders = encoders
        self.commanded_pwm = commanded_pwm
        self.on_change = on_change
        self.config = config or EncoderWatchConfig()
        self.failed = False
        self.failures = 0
        self._ticks: tuple[int, int] | None = None
        self._changed_s = 0.0
        self._driven_since_s: float | None = None
        self._failed_s = 0.0

    def check(self, now_s: float) -> None:
        """Look at the newest reading and the command now (called every ``period_s``)."""
        reading = self.encoders.latest()
        ticks = None if reading is None else (reading.left_ticks, reading.right_ticks)
        if ticks != self._ticks:
            self._ticks = ticks
            self._changed_s = now_s
            if self.failed and ticks is not None:
                self.failed = False
                back: dict[str, Any] = {"failed_for_s": round(now_s - self._failed_s, 2)}
                log.info("odometry.encoders_back", **back)
                self.on_change(False, back)
        pwm = self.commanded_pwm()
        if pwm < self.config.min_pwm:
            self._driven_since_s = None
            return
        if self._driven_since_s is None:
            self._driven_since_s = now_s
        frozen_s = now_s - max(self._changed_s, self._driven_since_s)
        if self.failed or frozen_s < self.config.freeze_s:
            return
        self.failed = True
        self.failures += 1
        self._failed_s = now_s
        stale = reading is None or now_s - reading.t_s >= self.config.freeze_s
        figures: dict[str, Any] = {"frozen_s": round(frozen_s, 2), "commanded_pwm": pwm,
                                   "reason": "no_telemetry" if stale else "frozen",
                                   "category": "encoder"}
        log.error("odometry.encoders_failed", **figures)
        self.on_change(True, figures)

    async def run(self) -> None:
        loop = asyncio.get_running_loop()
        while True:
            self.check(loop.time())
            await asyncio.sleep(self.config.period_s)
