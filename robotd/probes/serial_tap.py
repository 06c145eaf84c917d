"""What a board sent back, kept so that a failed handshake can say what came (or nothing).

The probe opens the port through ``ReceivedTap.open``: it puts a small protocol between the
serial transport and the stream's own protocol that counts the bytes and keeps the first few,
then hands every byte on unchanged. No task and no copy of the stream: the link's timing (the
probe's RTT figures) is what it would be without it, but for one call per chunk received.
"""

from __future__ import annotations

import asyncio
import contextlib
from typing import Any

from hal.ports import SerialOpener, StreamPair

EXCERPT_BYTES = 48


class ReceivedTap:
    """Wraps a SerialOpener; ``summary()`` says what the board sent on every opening."""

    def __init__(self, opener: SerialOpener) -> None:
        self._opener = opener
        self.opened = 0
        self.received_bytes = 0
        self.head = bytearray()

    async def open(self, port: str, baud: int) -> StreamPair:
        reader, writer = await self._opener(port, baud)
        self.opened += 1
        transport = writer.transport
        # A transport that cannot be tapped leaves the counts at 0: the probe still runs.
        with contextlib.suppress(NotImplementedError):
            transport.set_protocol(_TapProtocol(transport.get_protocol(), self))
        return reader, writer

    def record(self, data: bytes) -> None:
        self.received_bytes += len(data)
        if len(self.head) < EXCERPT_BYTES:
            self.head += data[: EXCERPT_BYTES - len(self.head)]

    def summary(self) -> str:
        """``nothing came from the board`` or ``received N bytes, first: '...'``."""
        if self.received_bytes == 0:
            return ("nothing came from the board (is it on this port, powered, at this baud "
                    "rate, running the robotd sketch?)")
        more = "" if self.received_bytes <= len(self.head) else " ..."
        return (f"received {self.received_bytes} bytes but no HELLO reply (wrong baud rate, "
                f"framing or sketch?); first bytes: '{printable(bytes(self.head))}'{more}")


def printable(data: bytes) -> str:
    """ASCII shown as is; newline as \\n; every other byte as \\xNN."""
    out = []
    for byte in data:
        if byte == 0x0A:
            out.append("\\n")
        elif byte == 0x0D:
            out.append("\\r")
        elif 0x20 <= byte < 0x7F and byte != 0x5C:
            out.append(chr(byte))
        else:
            out.append(f"\\x{byte:02x}")
    return "".join(out)


class _TapProtocol(asyncio.Protocol):
    """Hands everything to ``inner`` (the stream's protocol); records what is received."""

    def __init__(self, inner: Any, tap: ReceivedTap) -> None:
        self._inner = inner
        self._tap = tap

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        self._inner.connection_made(transport)

    def data_received(self, data: bytes) -> None:
        self._tap.record(data)
        self._inner.data_received(data)

    def eof_received(self) -> bool | None:
        result: bool | None = self._inner.eof_received()
        return result

    def connection_lost(self, exc: Exception | None) -> None:
        self._inner.connection_lost(exc)

    def pause_writing(self) -> None:
        self._inner.pause_writing()

    def resume_writing(self) -> None:
        self._inner.resume_writing()
