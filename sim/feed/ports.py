"""Where the feeder's devices meet the daemon's drivers: pseudo-terminals and named pipes."""

from __future__ import annotations

import asyncio
import contextlib
import errno
import os
import tty
from pathlib import Path

import structlog

from hal.ports import IrEdgeSource, StreamPair

log = structlog.get_logger(__name__)

REOPEN_S = 0.25


async def pty_streams(master: int) -> StreamPair:
    """Reader and writer on a pty's master side (the device's end of the cable)."""
    loop = asyncio.get_running_loop()
    reader = asyncio.StreamReader(loop=loop)
    protocol = asyncio.StreamReaderProtocol(reader, loop=loop)
    read_file = os.fdopen(os.dup(master), "rb", buffering=0)
    write_file = os.fdopen(os.dup(master), "wb", buffering=0)
    # The write side needs its own protocol (for drain); a reader takes one transport only.
    write_protocol = asyncio.StreamReaderProtocol(asyncio.StreamReader(loop=loop), loop=loop)
    await loop.connect_read_pipe(lambda: protocol, read_file)
    write_transport, _ = await loop.connect_write_pipe(lambda: write_protocol, write_file)
    return reader, asyncio.StreamWriter(write_transport, write_protocol, reader, loop)


def link_to(link: Path, target: str) -> None:
    """Point ``link`` at ``target`` atomically (a stable name, as udev's /dev/robotd-lidar)."""
    tmp = link.with_name(link.name + ".tmp")
    with contextlib.suppress(FileNotFoundError):
        tmp.unlink()
    tmp.symlink_to(target)
    tmp.replace(link)


class PtyLine:
    """A device's serial line on a pty: ``b`` is the device's end, ``link`` what a driver opens.

    What a ``SimLd19`` connects to (``connect_pipe``), as to the simulator's byte pipe."""

    def __init__(self, link: Path) -> None:
        self.link = link
        self.b: StreamPair
        self._fds: tuple[int, int] = (-1, -1)

    async def open(self) -> None:
        master, slave = os.openpty()
        tty.setraw(slave)  # no echo, no CR/LF translation: bytes pass as on a UART
        self._fds = (master, slave)
        link_to(self.link, os.ttyname(slave))
        self.b = await pty_streams(master)

    def break_(self) -> None:
        """The cable is pulled: the pty closes and the link goes."""
        self.b[1].close()
        for fd in self._fds:
            if fd >= 0:
                with contextlib.suppress(OSError):
                    os.close(fd)
        self._fds = (-1, -1)
        with contextlib.suppress(FileNotFoundError):
            self.link.unlink()


class EdgePipe:
    """Writes a ``hal.ports.IrEdgeSource``'s edges to a named pipe as ``T_US NAME LEVEL`` lines
    (what ``drivers.dock_ir.edge_stream`` reads). Edges while no reader has the pipe open are
    dropped, as a receiver's output is lost while nobody listens; ``dropped`` counts them."""

    def __init__(self, path: Path, source: IrEdgeSource) -> None:
        self.path = path
        self.source = source
        self.written = 0
        self.dropped = 0
        os.mkfifo(path)

    async def run(self) -> None:
        fd = -1
        try:
            while True:
                edges = await self.source.next_edges()
                if fd < 0:
                    fd = self._open()
                if fd < 0:
                    self.dropped += len(edges)
                    continue
                data = "".join(f"{e.t_us} {e.receiver} {int(e.level)}\n" for e in edges)
                try:
                    os.write(fd, data.encode("ascii"))
                    self.written += len(edges)
                except BlockingIOError:
                    self.dropped += len(edges)
                except BrokenPipeError:  # the reader went: open again when it is back
                    os.close(fd)
                    fd = -1
                    self.dropped += len(edges)
        finally:
            if fd >= 0:
                os.close(fd)

    def _open(self) -> int:
        try:
            return os.open(self.path, os.O_WRONLY | os.O_NONBLOCK)
        except OSError as exc:
            if exc.errno != errno.ENXIO:  # ENXIO: no reader yet
                raise
            return -1
