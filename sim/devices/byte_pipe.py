"""An in-memory serial line: two connected asyncio stream pairs with line faults.

Each direction delivers bytes in order on the event loop's clock: a write arrives after its
wire time (ten bit times a byte at ``baud``, queued behind earlier bytes) plus ``delay_s``.
``corrupt_fraction`` flips one random bit in that fraction of bytes, like noise on a UART,
from a seeded random generator so a run repeats exactly. ``break_()`` makes the line vanish:
the peer's next read raises OSError, as when a USB serial adapter is unplugged.
"""

from __future__ import annotations

import asyncio
import collections
import errno
import random
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from hal.ports import StreamPair


@dataclass
class LineFaults:
    """Faults of one direction; change them at any time."""

    corrupt_fraction: float = 0.0
    delay_s: float = 0.0


def corrupt_bytes(data: bytes, fraction: float, rng: random.Random) -> bytes:
    """``data`` with one random bit flipped in each byte chosen with probability ``fraction``."""
    if fraction <= 0.0:
        return data
    out = bytearray(data)
    for i in range(len(out)):
        if rng.random() < fraction:
            out[i] ^= 1 << rng.randrange(8)
    return bytes(out)


class _Direction:
    """Bytes written at one end, delivered to the other end's reader in order."""

    def __init__(self, loop: asyncio.AbstractEventLoop, baud: int | None, seed: int) -> None:
        self.loop = loop
        self.faults = LineFaults()
        self.rng = random.Random(seed)
        self.byte_s = 10.0 / baud if baud else 0.0
        self.busy_until_s = 0.0
        self.pending: collections.deque[tuple[float, bytes]] = collections.deque()
        self.timer: asyncio.TimerHandle | None = None
        self.receiver: Callable[[bytes], None] | None = None  # the far end's data_received
        self.sink: Callable[[bytes], None] | None = None  # takes the bytes instead
        self.bytes_sent = 0

    def send(self, data: bytes) -> None:
        loop = self.loop
        now = loop.time()
        faults = self.faults
        if faults.corrupt_fraction > 0.0:
            data = corrupt_bytes(data, faults.corrupt_fraction, self.rng)
        size = len(data)
        busy_s = self.busy_until_s
        # The wire is free at the later of now and the end of what it still carries.
        busy_s = (now if now >= busy_s else busy_s) + size * self.byte_s
        self.busy_until_s = busy_s
        pending = self.pending
        pending.append((busy_s + faults.delay_s, data))
        self.bytes_sent += size
        if self.timer is None:
            self.timer = loop.call_at(pending[0][0], self._deliver)

    def _deliver(self) -> None:
        self.timer = None
        now = self.loop.time()
        pending = self.pending
        while pending and pending[0][0] <= now:
            data = pending.popleft()[1]
            receive = self.sink or self.receiver
            if receive is not None:
                receive(data)
        if self.timer is None and pending:
            self.timer = self.loop.call_at(pending[0][0], self._deliver)

    def stop(self) -> None:
        if self.timer is not None:
            self.timer.cancel()
            self.timer = None
        self.pending.clear()


class PipeTransport(asyncio.Transport):
    """One end's transport: writes go into the outgoing direction, arriving bytes to the
    protocol (its ``data_received``)."""

    def __init__(self, pipe: BytePipe, out: _Direction, incoming: _Direction) -> None:
        super().__init__()
        self._pipe = pipe
        self._out = out
        self._in = incoming
        self._closing = False
        self.protocol: asyncio.Protocol | None = None

    def set_protocol(self, protocol: asyncio.BaseProtocol) -> None:
        assert isinstance(protocol, asyncio.Protocol)
        self.protocol = protocol
        self._in.receiver = protocol.data_received

    def get_protocol(self) -> asyncio.BaseProtocol:
        assert self.protocol is not None
        return self.protocol

    def write(self, data: bytes | bytearray | memoryview) -> None:
        if self._pipe.broken:
            raise OSError(errno.EIO, "serial line is gone")
        if self._closing:
            return
        self._out.send(data if type(data) is bytes else bytes(data))

    def is_closing(self) -> bool:
        return self._closing

    def close(self) -> None:
        if not self._closing:
            self._pipe.close()

    def abort(self) -> None:
        self._pipe.break_()

    def can_write_eof(self) -> bool:
        return False

    def get_write_buffer_size(self) -> int:
        return 0

    def get_extra_info(self, name: str, default: Any = None) -> Any:
        return {"peername": "byte-pipe"}.get(name, default)

    def _closed(self, exc: Exception | None) -> None:
        if self._closing:
            return
        self._closing = True
        if self.protocol is not None:
            self.protocol.connection_lost(exc)


class BytePipe:
    """A connected pair of stream ends: ``a`` (the host side) and ``b`` (the device side).

    Args:
        baud: wire speed for delivery times; None delivers at once (on the next loop turn).
        seed: seed of the corruption generators (each direction has its own).
    """

    def __init__(self, *, baud: int | None = None, seed: int = 0) -> None:
        loop = asyncio.get_running_loop()
        self.broken = False
        self.a_to_b = _Direction(loop, baud, seed * 2 + 1)
        self.b_to_a = _Direction(loop, baud, seed * 2 + 2)
        self._transports: list[PipeTransport] = []
        self.a = self._end(loop, self.a_to_b, self.b_to_a)
        self.b = self._end(loop, self.b_to_a, self.a_to_b)

    def _end(self, loop: asyncio.AbstractEventLoop, out: _Direction,
             incoming: _Direction) -> StreamPair:
        reader = asyncio.StreamReader(loop=loop)
        transport = PipeTransport(self, out, incoming)
        protocol = asyncio.StreamReaderProtocol(reader, loop=loop)
        transport.set_protocol(protocol)
        protocol.connection_made(transport)
        self._transports.append(transport)
        return reader, asyncio.StreamWriter(transport, protocol, reader, loop)

    def receive_at_b(self, sink: Callable[[bytes], None] | None) -> None:
        """Hand the bytes arriving at ``b`` to ``sink`` at their arrival time, not to b's reader.

        A simulated device served this way takes each write as one callback: no reader task
        to wake. None gives them back to b's protocol (its reader).
        """
        self.a_to_b.sink = sink

    def close(self) -> None:
        """Hang up cleanly: both readers see end of file."""
        for direction in (self.a_to_b, self.b_to_a):
            direction.stop()
        for transport in self._transports:
            transport._closed(None)

    def break_(self) -> None:
        """The line vanishes: reads and writes at both ends fail with OSError."""
        if self.broken:
            return
        self.broken = True
        for direction in (self.a_to_b, self.b_to_a):
            direction.stop()
        for transport in self._transports:
            transport._closed(OSError(errno.EIO, "serial line is gone"))
