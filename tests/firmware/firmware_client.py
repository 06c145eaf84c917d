"""A minimal host side of the serial link, written for the firmware tests only.

It frames and checks lines itself, with the bitwise CRC-8 of the simulated board
(``sim.devices.motor_board.mcu_frames``), so the firmware is tested against the contract
independently of ``drivers/arduino``.
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import tty

from sim.devices.motor_board.mcu_frames import (
    crc8_bitwise as crc8,  # the firmware's own bitwise CRC
)

_PLAIN_STARTS = ("ACK", "NAK:", "HELLO:", "ENCODER:", "IR:", "IRS:", "BAT:", "BOOT:", "DOCK:",
                 "BUMP:", "WALL:", "BIN:")
"""How the board's whole plain lines begin; the tail of a line cut by the port's opening
begins otherwise (a plain ACK, the first line a plain command gets, must not be dropped)."""


def frame(body: str) -> bytes:
    return f"{body}*{crc8(body.encode()):02X}\n".encode()


def unframe(line: str) -> str | None:
    """The BODY of a `BODY*CC` line, or None when the CRC is missing or wrong."""
    body, star, cc = line.rpartition("*")
    if not star or len(cc) != 2 or f"{crc8(body.encode()):02X}" != cc:
        return None
    return body


class PtyLink:
    """The host end of the emulated UART: raw lines in, raw lines out, telemetry kept apart."""

    def __init__(self, fd: int) -> None:
        self.fd = fd
        self.lines: asyncio.Queue[str] = asyncio.Queue()
        self.telemetry: list[str] = []
        self._buf = b""
        # Opening the port (tty.setraw flushes) can cut the line on the wire in two: like a
        # host resyncing, drop a first line that is no whole frame.
        self._synced = False
        asyncio.get_running_loop().add_reader(fd, self._on_readable)

    @classmethod
    def open(cls, path: str) -> PtyLink:
        fd = os.open(path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        tty.setraw(fd)
        return cls(fd)

    def _on_readable(self) -> None:
        try:
            self._buf += os.read(self.fd, 4096)
        except BlockingIOError:
            return
        *lines, self._buf = self._buf.split(b"\n")
        if lines and not self._synced:
            self._synced = True
            first = lines[0].decode(errors="replace")
            if unframe(first) is None and not first.startswith(_PLAIN_STARTS):
                lines = lines[1:]  # a tail: whole plain lines (a bare ACK first) are kept
        for raw in lines:
            line = raw.decode(errors="replace")
            body = unframe(line)
            text = body if body is not None else line
            is_reply = text.startswith("#") or text in ("ACK",) or text.startswith(
                ("NAK:", "HELLO:"))
            if is_reply:
                self.lines.put_nowait(line)
            else:
                self.telemetry.append(line)

    def send(self, data: bytes) -> None:
        os.write(self.fd, data)

    def drain_replies(self) -> None:
        while not self.lines.empty():
            self.lines.get_nowait()

    async def reply(self, timeout_s: float = 3.0) -> str:
        return await asyncio.wait_for(self.lines.get(), timeout_s)

    async def no_reply(self, within_s: float = 0.3) -> bool:
        try:
            await asyncio.wait_for(self.lines.get(), within_s)
        except TimeoutError:
            return True
        return False

    async def command(self, seq: int, payload: str, timeout_s: float = 3.0) -> str:
        """Sends `#SEQ PAYLOAD*CC` and returns the checked BODY of the reply."""
        self.send(frame(f"#{seq} {payload}"))
        line = await self.reply(timeout_s)
        body = unframe(line)
        assert body is not None, f"reply with a bad CRC: {line!r}"
        return body

    async def telemetry_matching(self, prefix: str, timeout_s: float = 5.0) -> str:
        """The next telemetry body starting with prefix (CRC-checked when framed)."""
        start = len(self.telemetry)
        async with asyncio.timeout(timeout_s):
            while True:
                for line in self.telemetry[start:]:
                    body = unframe(line)
                    text = body if body is not None else line
                    if text.startswith(prefix):
                        return text
                start = len(self.telemetry)
                await asyncio.sleep(0.02)

    def close(self) -> None:
        asyncio.get_running_loop().remove_reader(self.fd)
        with contextlib.suppress(OSError):
            os.close(self.fd)
