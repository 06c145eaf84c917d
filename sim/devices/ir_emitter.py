"""Simulated IR emitters and receiver pins: beam codes -> the edges a demodulating receiver gives.

The timing is the iRobot Open Interface's (bit 1 = 3 ms mark + 1 ms space, bit 0 = 1 ms +
3 ms, MSB first, a gap after the 8th bit), written here apart from the driver's decoder on
purpose: the fake checks the decoder, not itself. Everything is built as mark intervals
(start, end) in microseconds, so the damage a real room does is plain interval arithmetic:
two emitters colliding are the union of their marks (the receiver sees light from either),
a noise spike is a short extra mark, a dropped edge is an edge left out.

``SimIrEdgeSource`` is the ``hal.ports.IrEdgeSource`` of the simulator and the tests: edges
are pushed with their times and released in batches on the event loop's clock.
"""

from __future__ import annotations

import asyncio
import bisect
import random
from collections.abc import Callable, Iterable

from hal.ports import IrEdge

ONE_US = (3000, 1000)  # (mark, space) of a 1 bit
ZERO_US = (1000, 3000)
GAP_US = 20000  # after the 8th mark; Roomba captures show 19-21 ms
BATCH_S = 0.02

Marks = list[tuple[int, int]]


def code_marks(code: int, t0_us: int, *, jitter_us: int = 0,
               rng: random.Random | None = None) -> tuple[Marks, int]:
    """The 8 marks of one code starting at ``t0_us``, and when its last mark ends.

    Each pulse width (mark or space) is off by up to ``jitter_us`` either way.
    """
    if not 0 <= code <= 255:
        msg = f"an IR code is 0-255, got {code}"
        raise ValueError(msg)
    rng = rng or random.Random(0)
    marks: Marks = []
    t = t0_us
    for i in range(7, -1, -1):
        mark_us, space_us = ONE_US if code >> i & 1 else ZERO_US
        end = t + mark_us + _jitter(jitter_us, rng)
        marks.append((t, end))
        t = end + space_us + _jitter(jitter_us, rng)
    return marks, marks[-1][1]


def stream_marks(codes: Iterable[int], t0_us: int = 0, *, gap_us: int = GAP_US,
                 jitter_us: int = 0, rng: random.Random | None = None) -> tuple[Marks, int]:
    """Codes sent one after another with ``gap_us`` after each; the marks and the end time."""
    rng = rng or random.Random(0)
    marks: Marks = []
    t = t0_us
    for code in codes:
        frame, last_end = code_marks(code, t, jitter_us=jitter_us, rng=rng)
        marks += frame
        t = last_end + gap_us
    return marks, t


def union(*mark_lists: Marks) -> Marks:
    """What one receiver sees of several emitters at once: light while any of them is on."""
    out: Marks = []
    for start, end in sorted(m for marks in mark_lists for m in marks):
        if out and start <= out[-1][1]:
            out[-1] = (out[-1][0], max(out[-1][1], end))
        else:
            out.append((start, end))
    return out


def spikes(start_us: int, end_us: int, count: int, *, width_us: int = 80,
           rng: random.Random | None = None) -> Marks:
    """``count`` short noise marks (sunlight flicker, a lamp's ballast) between two times."""
    rng = rng or random.Random(0)
    out: Marks = []
    for _ in range(count):
        t = rng.randrange(start_us, max(start_us + 1, end_us - width_us))
        out.append((t, t + rng.randint(max(1, width_us // 4), width_us)))
    return out


def to_edges(marks: Marks, receiver: str, *, active_low: bool = True) -> list[IrEdge]:
    """The receiver pin's edges: low while it sees the carrier (demodulating receivers)."""
    mark_level = not active_low
    edges: list[IrEdge] = []
    for start, end in marks:
        edges.append(IrEdge(receiver, mark_level, start))
        edges.append(IrEdge(receiver, not mark_level, end))
    return edges


def drop(edges: list[IrEdge], fraction: float, rng: random.Random | None = None) -> list[IrEdge]:
    """Leave out each edge with probability ``fraction`` (an interrupt the kernel missed)."""
    rng = rng or random.Random(0)
    return [e for e in edges if rng.random() >= fraction]


def merge(*edge_lists: list[IrEdge]) -> list[IrEdge]:
    """Several receivers' edges as one stream, in time order."""
    return sorted((e for edges in edge_lists for e in edges), key=lambda e: e.t_us)


def _jitter(jitter_us: int, rng: random.Random) -> int:
    return rng.randint(-jitter_us, jitter_us) if jitter_us else 0


class SimIrEdgeSource:
    """``hal.ports.IrEdgeSource`` fed by the simulator: edges are released by their time.

    ``push`` queues edges stamped on this source's clock (the event loop's, in microseconds,
    unless ``clock_s`` is given); ``next_edges`` returns those whose time has come, at most
    once every ``batch_s``. It records how many batches it delivered (``batches``).
    """

    def __init__(self, *, clock_s: Callable[[], float] | None = None,
                 batch_s: float = BATCH_S) -> None:
        self._clock_s = clock_s
        self.batch_s = batch_s
        self._pending: list[IrEdge] = []
        self._times: list[int] = []
        self._wake = asyncio.Event()
        self.batches = 0
        self.edges = 0
        self.closed = False

    def now_us(self) -> int:
        clock = self._clock_s or asyncio.get_running_loop().time
        return round(clock() * 1e6)

    def push(self, edges: Iterable[IrEdge]) -> None:
        self._pending = sorted([*self._pending, *edges], key=lambda e: e.t_us)  # stable
        self._times = [e.t_us for e in self._pending]
        self._wake.set()

    async def next_edges(self) -> list[IrEdge]:
        while True:
            now = self.now_us()
            ready = bisect.bisect_right(self._times, now)
            if ready:
                batch = self._pending[:ready]
                del self._pending[:ready], self._times[:ready]
                self.batches += 1
                self.edges += len(batch)
                return batch
            if self._pending:
                await asyncio.sleep(max(self.batch_s, (self._times[0] - now) / 1e6))
            else:
                self._wake.clear()
                await self._wake.wait()

    def close(self) -> None:
        self.closed = True
