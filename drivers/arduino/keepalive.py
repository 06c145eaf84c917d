"""Keeping a connection to the motor board alive, and noticing when it is not.

A heartbeat (``HB``) goes out when no wheel command did for ``heartbeat_s``, so the board's
500 ms deadman does not stop wheels the robot means to keep turning; the watchdog gives the
connection up when no intact line came from the board for ``silence_s``. Each look at the
clock is a timer callback (``hal.looptime.timer_chain``), not a task waking from a sleep: wheel
commands push the heartbeat back several times a second.
"""

from __future__ import annotations

import asyncio
from typing import TYPE_CHECKING

from drivers.arduino.outbox import Command, Kind
from drivers.arduino.receiver import LinkBroken
from hal.looptime.timer_chain import timer_chain

if TYPE_CHECKING:
    from drivers.arduino.session import Session

# The loop runs timers up to its clock resolution early; closer than this counts as due.
CLOCK_SLACK_S = 1e-6


async def send_heartbeats(session: Session) -> None:
    """Queue ``HB`` whenever ``heartbeat_s`` passed since the last MOTOR or HB went out."""
    loop = asyncio.get_running_loop()
    period_s = session.config.heartbeat_s
    outbox = session.outbox

    def check() -> float:
        due_s = session.last_drive_tx_s + period_s
        now = loop.time()
        if now < due_s - CLOCK_SLACK_S:
            return due_s - now
        inflight = session.inflight
        busy = inflight is not None and inflight.command.kind in (Kind.MOTOR, Kind.HEARTBEAT)
        if not busy and not outbox.has(Kind.MOTOR) and not outbox.has(Kind.HEARTBEAT):
            outbox.put(Command("HB", None))
        return period_s

    await timer_chain(check)


async def watch_silence(session: Session) -> None:
    """Raise LinkBroken once no intact line arrived for ``silence_s``."""
    loop = asyncio.get_running_loop()
    limit_s = session.config.silence_s

    def check() -> float:
        silent_s = loop.time() - session.last_rx_s
        if silent_s >= limit_s - CLOCK_SLACK_S:
            msg = f"no intact line from the MCU for {silent_s:.2f} s"
            raise LinkBroken(msg)
        return limit_s - silent_s

    await timer_chain(check)
