"""Bytes from the motor board become parsed lines, handed on as they arrive.

``LineReceiver`` takes the ``StreamReader``'s place as the port transport's protocol: each
chunk is split into lines and each line parsed in the transport's own callback, so no reader
task wakes per chunk and no StreamReader buffers in between (the simulator receives forty-odd
lines a simulated second, a motor board on a real port as many). The transport's other calls
(end of the connection, write flow control) still reach the stream pair's own protocol, so
the writer drains and closes as before. A stream pair whose reader has its own transport, or
has already buffered bytes, is read by ``pump()`` instead: the same lines, from a task.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable

import structlog

from drivers.arduino.framing import MAX_LINE_BYTES, Framing, Line, parse_line
from drivers.arduino.stats import LinkCounters
from hal.ports import StreamPair

log = structlog.get_logger(__name__)

# Received lines whose parse is remembered (they are immutable; the memo is cleared when full).
PARSED_LINES_KEPT = 1024
READ_CHUNK_BYTES = 512


class LinkBroken(Exception):
    """The connection failed (EOF, I/O error, silence); the link reconnects."""


class LineReceiver(asyncio.Protocol):
    """Splits received bytes into lines of at most 64 bytes and hands each on parsed.

    Args:
        framing: how lines are parsed.
        counters: counts overlong lines.
        on_line: gets each line, in order.
        on_lost: gets why the connection ended (LinkBroken at end of file), once; also what
            ``on_line`` raised, after which further bytes are ignored.
    """

    def __init__(self, framing: Framing, counters: LinkCounters,
                 on_line: Callable[[Line], None],
                 on_lost: Callable[[BaseException], None]) -> None:
        self._framing = framing
        self._counters = counters
        self._on_line = on_line
        self._on_lost = on_lost
        self._buffer = bytearray()
        self._discarding = False  # the rest of an overlong line is still coming
        self._parsed: dict[bytes, Line] = {}
        self._inner: asyncio.BaseProtocol | None = None  # the stream pair's own protocol
        self._ended = False

    def attach(self, streams: StreamPair) -> bool:
        """Receive in the reader's place on its transport; False when that cannot be done
        (then run ``pump(reader)``)."""
        reader, writer = streams
        transport = writer.transport
        try:
            inner = transport.get_protocol()
        except NotImplementedError:
            return False
        # A StreamReaderProtocol holds its reader as _stream_reader, a StreamReader its
        # unread bytes as _buffer (asyncio internals, unchanged since Python 3.8).
        unread = getattr(reader, "_buffer", None)
        if (getattr(inner, "_stream_reader", None) is not reader
                or not isinstance(unread, bytearray) or unread or reader.at_eof()
                or reader.exception() is not None):
            return False
        try:
            transport.set_protocol(self)
        except NotImplementedError:
            return False
        self._inner = inner
        return True

    async def pump(self, reader: asyncio.StreamReader) -> None:
        """Read ``reader`` until the connection ends (for stream pairs ``attach`` refused)."""
        while not self._ended:
            try:
                chunk = await reader.read(READ_CHUNK_BYTES)
            except OSError as exc:
                self._end(exc)
                return
            if not chunk:
                self._end(None)
                return
            self.data_received(chunk)

    # -- asyncio.Protocol --------------------------------------------------------------------
    def data_received(self, data: bytes) -> None:
        if self._ended:
            return
        if type(data) is not bytes:
            data = bytes(data)
        try:
            if self._buffer or self._discarding or not data.endswith(b"\n"):
                self._split(data)
            elif data.find(b"\n") == len(data) - 1:
                self._line(data[:-1])  # the usual chunk: exactly one whole line
            else:
                # A telemetry tick's few whole lines: split as they are, no buffer between.
                for raw in data[:-1].split(b"\n"):
                    self._line(raw)
        except Exception as exc:
            self._end(exc)

    def _split(self, data: bytes) -> None:
        buffer = self._buffer
        buffer += data
        while True:
            end = buffer.find(b"\n")
            if end < 0:
                break
            line = bytes(buffer[:end])
            del buffer[: end + 1]
            if self._discarding:
                self._discarding = False
                continue
            self._line(line)
        if len(buffer) >= MAX_LINE_BYTES:
            self._counters.overlong += 1
            log.warning("link.overlong_line", head=bytes(buffer[:16]))
            buffer.clear()
            self._discarding = True

    def _line(self, raw: bytes) -> None:
        # Lines repeat (an ACK per SEQ, IR and BAT values, ENCODER at rest): parse each once.
        line = self._parsed.get(raw)
        if line is None:
            if len(raw) >= MAX_LINE_BYTES:  # with its '\n', longer than a line may be
                self._counters.overlong += 1  # (never remembered, so looked at here)
                return
            line = parse_line(raw, self._framing)
            if len(self._parsed) >= PARSED_LINES_KEPT:
                self._parsed.clear()
            self._parsed[raw] = line
        self._on_line(line)

    def connection_lost(self, exc: Exception | None) -> None:
        if self._inner is not None:
            self._inner.connection_lost(exc)  # the reader sees the end, the writer closes
        self._end(exc)

    def eof_received(self) -> bool | None:
        if isinstance(self._inner, asyncio.Protocol):
            return self._inner.eof_received()
        return None

    def pause_writing(self) -> None:
        if self._inner is not None:
            self._inner.pause_writing()

    def resume_writing(self) -> None:
        if self._inner is not None:
            self._inner.resume_writing()

    def _end(self, exc: BaseException | None) -> None:
        if not self._ended:
            self._ended = True
            self._on_lost(exc or LinkBroken("port closed (end of file)"))
