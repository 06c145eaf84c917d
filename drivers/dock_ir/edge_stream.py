"""``hal.ports.IrEdgeSource`` on a named pipe of edges, one text line each: ``T_US NAME LEVEL``.

For a board whose receivers are not on lgpio's GPIO lines, or to replay edges a bench
recorded: whatever writes the pipe (``mkfifo``) gives each level change of a receiver's output
as ``T_US NAME LEVEL``, e.g. ``8123456789 omni 0``: the time in microseconds on the system's
monotonic clock (CLOCK_MONOTONIC, the clock the kernel's GPIO character device stamps edges
with by default, and the event loop's), the receiver's name (``omni``, ``front_left``, ...),
and the new level, 0 or 1. The decoder measures widths from these times, never from when the
line arrives, so a writer may send a frame's edges at once or late.

The pipe is read without blocking (``loop.add_reader``); the loop then waits ``batch_s`` more,
so it wakes about 1 / batch_s times a second, never once per edge, as with lgpio. It is opened
for reading and writing, so a writer that comes and goes is no end of file: its absence is
silence, which the docking behaviour already reports (``dock.ir_silent``). A line that does
not parse is counted (``bad_lines``) and skipped.
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
from hal.ports import IrEdge

log = structlog.get_logger(__name__)

BATCH_S = 0.02
MAX_LINE_BYTES = 256
READ_BYTES = 65536


def parse_edge(line: bytes, receivers: frozenset[str]) -> IrEdge | None:
    """One ``T_US NAME LEVEL`` line as an edge; None when it is not one of ``receivers``'."""
    parts = line.split()
    if len(parts) != 3 or parts[2] not in (b"0", b"1"):
        return None
    try:
        t_us = int(parts[0])
        name = parts[1].decode("ascii")
    except (ValueError, UnicodeDecodeError):
        return None
    if t_us < 0 or name not in receivers:
        return None
    return IrEdge(name, parts[2] == b"1", t_us)


class StreamIrEdges:
    """The edges written to the named pipe ``path``, in batches."""

    def __init__(self, path: str | Path, receivers: tuple[str, ...],
                 loop: asyncio.AbstractEventLoop, *, batch_s: float = BATCH_S) -> None:
        self.path = Path(path)
        self.batch_s = batch_s
        self.bad_lines = 0
        self._receivers = frozenset(receivers)
        self._loop = loop
        self._buffer: list[IrEdge] = []
        self._partial = b""
        self._wake = asyncio.Event()
        self._fd = open_line_pipe(self.path, "dock_ir", "docking.ir_stream", char_device=True)
        loop.add_reader(self._fd, self._on_readable)

    def _on_readable(self) -> None:
        try:
            data = os.read(self._fd, READ_BYTES)
        except BlockingIOError:
            return
        lines = (self._partial + data).split(b"\n")
        self._partial = lines.pop()
        if len(self._partial) > MAX_LINE_BYTES:
            self.bad_lines += 1
            self._partial = b""
        for line in lines:
            edge = parse_edge(line, self._receivers)
            if edge is not None:
                self._buffer.append(edge)
            elif line.strip():
                if self.bad_lines == 0:
                    log.warning("dock_ir.bad_line", path=str(self.path), line=line[:80])
                self.bad_lines += 1
        if self._buffer:
            self._wake.set()

    async def next_edges(self) -> list[IrEdge]:
        while True:
            self._wake.clear()
            if self._buffer:
                await asyncio.sleep(self.batch_s)  # let the rest of the frame come
                batch, self._buffer = self._buffer, []
                return batch
            await self._wake.wait()

    def now_us(self) -> int:
        return time.monotonic_ns() // 1000

    def close(self) -> None:
        fd, self._fd = self._fd, -1
        if fd < 0:
            return
        with contextlib.suppress(Exception):  # the loop may be closing
            self._loop.remove_reader(fd)
        os.close(fd)


def stream_edges_opener(path: str | Path, receivers: tuple[str, ...]
                        ) -> Callable[[], StreamIrEdges]:
    """What ``DockIrReceivers`` takes as ``open_source`` for ``docking.ir_source = "stream"``."""
    return lambda: StreamIrEdges(path, receivers, asyncio.get_running_loop())
