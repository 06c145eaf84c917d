"""``hal.ports.Hx711Lines`` in front of a named pipe of conversions, one signed code a line.

For ``hx711.source = "stream"``: an HX711 that another board reads and forwards (its codes
written to the pipe ``hx711.stream``, made with ``mkfifo``), or a recording of one replayed.
The driver above is the same as on GPIO lines: it waits for DOUT low, clocks the 24 bits out
MSB first and gives the gain pulses, filters, tares and calibrates. These lines answer as the
chip's serial side does: DOUT falls when a conversion is waiting (a newer one replaces it, as
the chip's register is overwritten), each rising PD_SCK edge shifts the next bit out, and
after the 24th bit DOUT goes high until the next conversion; a pulse takes no time
(``pulse_sck``, ``hal.ports.SckPulse``: no chip here powers down). ``on_dout_low``
(``hal.ports.DoutAlert``) calls back when a code arrives, so the driver does not poll.

The pipe is opened for reading and writing (a writer that comes and goes is no end of file:
the driver's data-ready timeout reports the silence). A line that is not a code in the 24-bit
range is counted (``bad_lines``) and skipped.
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import time
from collections.abc import Callable
from pathlib import Path

import structlog

from drivers.pipe_source import open_line_pipe

log = structlog.get_logger(__name__)

CODE_MIN, CODE_MAX = -0x800000, 0x7FFFFF
READ_BYTES = 4096
DATA_BITS = 24
PULSE_US = 1
GAIN_PULSES = DATA_BITS + 1  # the state after the data: 1-3 gain pulses, no data


def parse_code(line: bytes) -> int | None:
    """One line as a signed 24-bit code; None when it is not one."""
    try:
        code = int(line.strip())
    except ValueError:
        return None
    return code if CODE_MIN <= code <= CODE_MAX else None


class StreamHx711Lines:
    """DOUT and PD_SCK of an HX711 whose conversions arrive on the pipe ``path``."""

    def __init__(self, path: str | Path, loop: asyncio.AbstractEventLoop) -> None:
        self.path = Path(path)
        self.bad_lines = 0
        self.codes = 0
        self._loop = loop
        self._waiting: int | None = None  # the conversion DOUT low announces
        self._shifting = 0  # the 24 bits being clocked out (two's complement, unsigned)
        self._bit = 0  # 0: between reads; 1-24: the data bit shifted out; GAIN_PULSES
        self._sck = False
        self._partial = b""
        self._alerts: list[Callable[[], None]] = []
        self._fd = open_line_pipe(self.path, "hx711", "hx711.stream")
        loop.add_reader(self._fd, self._on_readable)

    def _on_readable(self) -> None:
        try:
            data = os.read(self._fd, READ_BYTES)
        except BlockingIOError:
            return
        lines = (self._partial + data).split(b"\n")
        self._partial = lines.pop()[-64:]
        for line in lines:
            code = parse_code(line) if line.strip() else None
            if code is None:
                if line.strip():
                    if self.bad_lines == 0:
                        log.warning("hx711.bad_line", path=str(self.path), line=line[:40])
                    self.bad_lines += 1
                continue
            self.codes += 1
            self._waiting = code
        if self._waiting is not None and self._bit in (0, GAIN_PULSES):
            alerts, self._alerts = self._alerts, []
            for alert in alerts:
                alert()

    # --- the chip's serial side -------------------------------------------------------------
    def read_dout(self) -> bool:
        if 0 < self._bit <= DATA_BITS:  # mid-read: the bit the last rising edge shifted out
            return bool((self._shifting >> (DATA_BITS - self._bit)) & 1)
        self._bit = 0  # a read after the gain pulses: the next conversion is awaited
        return self._waiting is None  # low: a conversion is ready

    def set_sck(self, high: bool) -> None:
        rising = high and not self._sck
        self._sck = high
        if not rising:
            return
        if self._bit == GAIN_PULSES:
            return  # the gain pulses after the data (25-27 in all) shift nothing out
        if self._bit == 0:
            if self._waiting is None:
                return  # no conversion ready: the pulse shifts nothing
            self._shifting = self._waiting & 0xFFFFFF
            self._waiting = None
        self._bit += 1

    def now_us(self) -> int:
        return time.monotonic_ns() // 1000

    # hal.ports.SckPulse: no wire and no chip here to power down, so a pulse takes no time
    # (on GPIO lines a pulse held high past 60 us resets the chip and the read is dropped).
    def pulse_sck(self) -> int:
        self.set_sck(True)
        self.set_sck(False)
        return PULSE_US

    def pulse_sck_read(self) -> tuple[int, bool]:
        self.set_sck(True)
        self.set_sck(False)
        return PULSE_US, self.read_dout()

    def on_dout_low(self, callback: Callable[[], None]) -> Callable[[], None]:
        if self._waiting is not None and self._bit in (0, GAIN_PULSES):
            handle = self._loop.call_soon(callback)
            return handle.cancel
        self._alerts.append(callback)

        def cancel() -> None:
            with contextlib.suppress(ValueError):
                self._alerts.remove(callback)

        return cancel

    def close(self) -> None:
        fd, self._fd = self._fd, -1
        if fd < 0:
            return
        with contextlib.suppress(Exception):
            self._loop.remove_reader(fd)
        os.close(fd)
