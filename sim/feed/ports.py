"""Where the feeder's devices meet the daemon's drivers: pseudo-terminals and named pipes."""

from __future__ import annotations

import asyncio
import contextlib
import errno
import os
import tty
from collections.abc import Callable
from pathlib import Path

from bleak.backends.device import BLEDevice
from bleak.backends.scanner import AdvertisementData

from drivers.ble_stream import advert_line
from drivers.hx711 import Gain, ReadDiscarded, clock_out
from drivers.hx711_ready import wait_dout_low
from hal.ports import Hx711Lines, IrEdgeSource, StreamPair
from sim.devices.motor_board.pty_mcu import link_to, pty_streams


class PtyLine:
    """A device's serial line on a pty: ``b`` is the device's end, ``link`` what a driver opens.

    What a ``SimLd19`` connects to (``connect_pipe``), as to the simulator's byte pipe."""

    def __init__(self, link: Path) -> None:
        self.link = link
        self.b: StreamPair
        self._fds: tuple[int, int] = (-1, -1)
        self._transports: list[asyncio.BaseTransport] = []

    async def open(self) -> None:
        master, slave = os.openpty()
        tty.setraw(slave)  # no echo, no CR/LF translation: bytes pass as on a UART
        self._fds = (master, slave)
        link_to(self.link, os.ttyname(slave))
        self.b, self._transports = await pty_streams(master)

    def break_(self) -> None:
        """The cable is pulled: the pty closes and the link goes."""
        for transport in self._transports:
            transport.close()
        self._transports = []
        for fd in self._fds:
            if fd >= 0:
                with contextlib.suppress(OSError):
                    os.close(fd)
        self._fds = (-1, -1)
        with contextlib.suppress(FileNotFoundError):
            self.link.unlink()


class LinePipe:
    """Lines written to a named pipe that the daemon's driver reads. Lines while no reader has
    the pipe open, or while it is full, are dropped, as a signal is lost while nobody listens;
    ``written`` and ``dropped`` count them."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.written = 0
        self.dropped = 0
        self._fd = -1
        os.mkfifo(path)

    def write(self, lines: list[str]) -> None:
        if self._fd < 0:
            self._fd = self._open()
        if self._fd < 0:
            self.dropped += len(lines)
            return
        try:
            os.write(self._fd, "".join(lines).encode("ascii"))
            self.written += len(lines)
        except BlockingIOError:
            self.dropped += len(lines)
        except BrokenPipeError:  # the reader went: open again when it is back
            self.close()
            self.dropped += len(lines)

    def _open(self) -> int:
        try:
            return os.open(self.path, os.O_WRONLY | os.O_NONBLOCK)
        except OSError as exc:
            if exc.errno != errno.ENXIO:  # ENXIO: no reader yet
                raise
            return -1

    def close(self) -> None:
        fd, self._fd = self._fd, -1
        if fd >= 0:
            os.close(fd)


async def pipe_edges(source: IrEdgeSource, pipe: LinePipe) -> None:
    """A ``hal.ports.IrEdgeSource``'s edges as ``T_US NAME LEVEL`` lines (what
    ``drivers.dock_ir.edge_stream`` reads), until cancelled."""
    try:
        while True:
            edges = await source.next_edges()
            pipe.write([f"{e.t_us} {e.receiver} {int(e.level)}\n" for e in edges])
    finally:
        pipe.close()


async def pipe_conversions(lines: Hx711Lines, pipe: LinePipe, gain: Gain,
                           timeout_s: float = 1.0) -> None:
    """An HX711's conversions, clocked out of its lines by the real driver's ``clock_out``,
    one code a line (what ``drivers.hx711_stream`` reads), until cancelled."""
    lines.set_sck(False)  # power up
    try:
        while True:
            if not await wait_dout_low(lines, timeout_s):
                continue
            try:
                pipe.write([f"{clock_out(lines, gain)}\n"])
            except ReadDiscarded:
                continue
    finally:
        pipe.close()


def advert_writer(pipe: LinePipe) -> Callable[[BLEDevice, AdvertisementData], None]:
    """A bleak detection callback that writes each advert as a JSON line (what
    ``drivers.ble_stream`` reads)."""
    def write(device: BLEDevice, adv: AdvertisementData) -> None:
        pipe.write([advert_line(device.address, adv)])

    return write
