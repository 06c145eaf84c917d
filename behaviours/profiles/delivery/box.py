"""The parcel box: the servo opens it at 90 degrees and closes it at 0 (seed section 8).

The motor board has no servo position feedback: the ``SERVO`` command is acknowledged once the
board has set the pulse width, and a hobby servo then turns 90 degrees in about 0.3 s. So
"reached its place within 2 s" is read as "the board acknowledged ``SERVO:<angle>`` within 2 s";
a move that is not acknowledged (link down, board busy, NAK) is sent again, 3 attempts in all,
and then logged and reported: the delivery goes on and the box is opened by hand (error table).
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable

import structlog

from behaviours.profiles.delivery.states import BOX_CLOSED_DEG, BOX_OPEN_DEG
from hal.devices import ServoBox
from hal.telemetry import NULL_TELEMETRY, Telemetry

log = structlog.get_logger(__name__)

SERVO_REACH_S = 2.0
SERVO_ATTEMPTS = 3


class BoxController:
    """Opens and closes the box through a `hal.devices.ServoBox`; never raises on a failed move.

    Args:
        servo: the box servo (the motor board's ``SERVO`` command).
        emit: the robot's event sink; a move that failed 3 times is a ``delivery.servo_failed``
            event an operator sees.
        telemetry: the live view (``delivery/box``: the angle acknowledged, open or not).
    """

    def __init__(self, servo: ServoBox, emit: Callable[..., None] | None = None, *,
                 reach_s: float = SERVO_REACH_S, attempts: int = SERVO_ATTEMPTS,
                 telemetry: Telemetry = NULL_TELEMETRY) -> None:
        self.servo = servo
        self.telemetry = telemetry
        self.emit = emit
        self.reach_s = reach_s
        self.attempts = attempts
        self.angle_deg: int | None = None
        """The last angle the board acknowledged (None: unknown, e.g. after a failed move)."""
        self.failed_moves = 0

    @property
    def is_open(self) -> bool:
        return self.angle_deg is not None and self.angle_deg != BOX_CLOSED_DEG

    async def open(self) -> bool:
        return await self.move(BOX_OPEN_DEG)

    async def close(self) -> bool:
        return await self.move(BOX_CLOSED_DEG)

    async def move(self, angle_deg: int) -> bool:
        """Move to ``angle_deg``; True once acknowledged, False after every attempt failed."""
        errors: list[str] = []
        for attempt in range(1, self.attempts + 1):
            try:
                async with asyncio.timeout(self.reach_s):
                    await self.servo.set_angle(angle_deg)
            except Exception as exc:  # any failure of the device is a failed attempt
                errors.append(f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__)
                log.warning("delivery.servo_retry", angle_deg=angle_deg, attempt=attempt,
                            error=errors[-1])
                continue
            self.angle_deg = angle_deg
            self.telemetry.values("delivery/box", angle_deg=angle_deg, open=self.is_open)
            return True
        self.angle_deg = None
        self.failed_moves += 1
        self.telemetry.values("delivery/box", angle_deg=None, open=None, failed=angle_deg)
        log.error("delivery.servo_failed", angle_deg=angle_deg, attempts=self.attempts,
                  errors=errors, action="manual box opening required")
        if self.emit is not None:
            self.emit("delivery.servo_failed", angle_deg=angle_deg, attempts=self.attempts,
                      error=errors[-1] if errors else "")
        return False
