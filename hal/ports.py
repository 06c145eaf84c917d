"""Low-level ports that real drivers are written against, and that the simulator provides.

A port is the narrowest thing a driver needs from the operating system: a byte stream for a
serial line, two GPIO lines for the HX711, a source of edge timestamps for IR receivers, BLE
adverts for the scanner. The real implementation wraps the OS library; ``sim`` feeds the
same port from the simulated world, so the real driver code runs in both.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from dataclasses import dataclass
from datetime import UTC, datetime
from typing import Protocol, runtime_checkable

StreamPair = tuple[asyncio.StreamReader, asyncio.StreamWriter]


@runtime_checkable
class SerialOpener(Protocol):
    """Opens a serial port as an asyncio stream pair (raises OSError when it is absent)."""

    async def __call__(self, port: str, baud: int) -> StreamPair: ...


@runtime_checkable
class Hx711Lines(Protocol):
    """The HX711's two wires: PD_SCK (output) and DOUT (input), plus a microsecond clock."""

    def set_sck(self, high: bool) -> None: ...
    def read_dout(self) -> bool: ...
    def now_us(self) -> int: ...


@runtime_checkable
class DoutAlert(Protocol):
    """What ``Hx711Lines`` may also offer: a call when DOUT falls, so a reader need not poll.

    ``on_dout_low(callback)`` calls ``callback()`` once, on the event loop's thread, when DOUT
    goes low (soon when it already is). It is a hint: it may come a little early or for a
    glitch, so the reader confirms by reading DOUT. Returns a function that cancels the call.
    """

    def on_dout_low(self, callback: Callable[[], None]) -> Callable[[], None]: ...


@runtime_checkable
class SckPulse(Protocol):
    """What ``Hx711Lines`` may also offer: a clock pulse in one call.

    ``pulse_sck()`` does what ``t0 = now_us(); set_sck(True); set_sck(False)`` and then
    ``now_us() - t0`` do, and returns that: how long PD_SCK was high, in ``now_us``'s
    microseconds. ``pulse_sck_read()`` then also does ``read_dout()`` and returns both. One
    call per bit instead of four or five (a read has 25 to 27 pulses).
    """

    def pulse_sck(self) -> int: ...
    def pulse_sck_read(self) -> tuple[int, bool]: ...


@dataclass(frozen=True, slots=True)
class IrEdge:
    """One level change on an IR receiver's pin: the level after it, and when (microseconds)."""

    receiver: str
    level: bool
    t_us: int


@runtime_checkable
class IrEdgeSource(Protocol):
    """Edges seen by the IR receivers, delivered in batches (never a loop wake-up per edge).

    ``next_edges`` waits for at least one edge and returns every edge pending, oldest first.
    ``now_us`` reads the clock the edges are stamped with, so a reader can tell that a line
    has been quiet long enough to close a frame.
    """

    async def next_edges(self) -> list[IrEdge]: ...
    def now_us(self) -> int: ...
    def close(self) -> None: ...


WallClock = Callable[[], datetime]
"""The one source of wall-clock timestamps (logs, fleet protocol); injected everywhere."""


def system_wall_clock() -> datetime:
    return datetime.now(UTC)
