"""The fake motor board's serial port: bytes in become lines, lines out leave as bytes.

``McuUart`` is the part of the firmware that sits at the UART, and the bench's faults on it:
received bytes are gathered into lines as the sketch reads them (CR skipped, past 63 bytes
dropped and the line marked overlong), ignored while the bootloader has the port; outgoing
bytes are damaged (``corrupt_fraction`` of them get one bit flipped) and held back
(``reply_delay_s``) as asked, and simply lost when nobody reads the port. One seeded
generator damages both directions, so a run repeats exactly.
"""

from __future__ import annotations

import asyncio
import collections
import random
from collections.abc import Callable

from sim.devices.byte_pipe import corrupt_bytes

LINE_MAX = 64  # bytes per line including '\n'
TX_BACKLOG_BYTES = 4096


def _running_loop_time() -> float:
    return asyncio.get_running_loop().time()


class McuUart:
    """Line assembly in, damaged and delayed transmission out.

    Args:
        on_line: gets each received line (without ``\\n``) and whether it was overlong.
        seed: seed of the corruption generator.
    """

    def __init__(self, on_line: Callable[[bytes, bool], None], *, seed: int = 0) -> None:
        self.on_line = on_line
        self.corrupt_fraction = 0.0
        self.reply_delay_s = 0.0
        self.deaf_until_s = float("-inf")  # the bootloader has the port until then
        self._rng = random.Random(seed)
        self._line = bytearray()  # the line being received
        self._overlong = False
        self._transport: asyncio.WriteTransport | None = None
        self._backlog_possible = True
        self._pending: collections.deque[tuple[float, bytes]] = collections.deque()
        self._timer: asyncio.TimerHandle | None = None
        self.clock: Callable[[], float] = _running_loop_time  # the serving loop's time()

    def attach(self, transport: asyncio.WriteTransport, *, backlog_possible: bool) -> None:
        """Send through ``transport``; ``backlog_possible`` False when it never buffers."""
        self.detach()
        self._transport = transport
        self._backlog_possible = backlog_possible
        self.clock = asyncio.get_running_loop().time  # looked up once, not per line

    def detach(self) -> None:
        """The port is gone: the partial line, and replies held back, are lost."""
        self._transport = None
        self._line.clear()
        self._overlong = False
        self._pending.clear()
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None

    # -- receiving ---------------------------------------------------------------------------
    def receive(self, chunk: bytes) -> None:
        """Bytes that arrived at the board."""
        if self.clock() < self.deaf_until_s:
            return  # the bootloader has the UART: the sketch never sees these bytes
        if self.corrupt_fraction > 0.0:
            chunk = corrupt_bytes(chunk, self.corrupt_fraction, self._rng)
        start = 0
        on_line = self.on_line
        while (end := chunk.find(b"\n", start)) >= 0:
            piece = chunk[start:end]
            if not self._line and len(piece) < LINE_MAX and b"\r" not in piece:
                on_line(piece, False)  # the usual write: one whole line
            else:
                self._take(piece)
                line, overlong = bytes(self._line), self._overlong
                self._line.clear()
                self._overlong = False
                on_line(line, overlong)
            start = end + 1
        if start < len(chunk):
            self._take(chunk[start:])

    def _take(self, piece: bytes) -> None:
        """Add bytes to the line as the firmware does: CR skipped, past 63 bytes dropped."""
        if b"\r" in piece:
            piece = piece.replace(b"\r", b"")
        room = LINE_MAX - 1 - len(self._line)
        if len(piece) > room:
            piece = piece[:room]
            self._overlong = True
        self._line += piece

    # -- sending -----------------------------------------------------------------------------
    def send(self, data: bytes) -> None:
        """Framed lines, in one write (as a UART's buffer drains them)."""
        if self._transport is None:
            return
        if self.corrupt_fraction > 0.0:
            data = corrupt_bytes(data, self.corrupt_fraction, self._rng)
        if self.reply_delay_s <= 0 and not self._pending:
            self._write(data)
            return
        loop = asyncio.get_running_loop()
        self._pending.append((loop.time() + self.reply_delay_s, data))
        if self._timer is None:
            self._timer = loop.call_at(self._pending[0][0], self._flush)

    def _write(self, data: bytes) -> None:
        transport = self._transport
        if transport is None:
            return
        # Nobody reading the port: a UART's bytes are simply gone.
        if self._backlog_possible and transport.get_write_buffer_size() > TX_BACKLOG_BYTES:
            return
        try:
            transport.write(data)
        except (OSError, RuntimeError):
            return  # the line is gone (cheaper than contextlib.suppress per write)

    def _flush(self) -> None:
        self._timer = None
        loop = asyncio.get_running_loop()
        while self._pending and self._pending[0][0] <= loop.time():
            self._write(self._pending.popleft()[1])
        if self._pending:
            self._timer = loop.call_at(self._pending[0][0], self._flush)
