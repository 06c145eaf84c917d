"""The incremental LD19 packet parser: bytes in any chunking -> checked packet records. No I/O.

How it finds packets: every ``54 2C`` in the buffer is a candidate header; the CRC (and the
plausibility checks below) of all complete candidates are computed at once with numpy, then
one pass takes them in order. An accepted packet moves the search past its 47 bytes; a
rejected one moves it only to the byte after its header, so a truncated packet costs only
itself and never its intact neighbour (LDROBOT's SDK skips 47 bytes there). ``54 2C``
inside an accepted packet's distances is never taken for a header.

Plausibility (a damaged packet passes CRC-8 one time in 256): the speed must be 1-7200
deg/s (the LD19 runs 5-13 Hz), both angles below 360 deg, and the span from the first to
the last point between 0.5x and 1.5x what eleven point intervals cover at the packet's own
speed and the model's point rate. The SDK checks only the upper bound (1.5x of twelve
intervals); the lower bound rejects as many random spans and a real sensor never comes
near it: at 10 Hz the LD19's span is 8.8 deg, the STL-19P's 7.9 deg, 0.9x of the LD19's.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from drivers.lidar.crc import TABLE, crc8_rows
from drivers.lidar.packet import (
    FULL_CIRCLE_CDEG,
    HEADER,
    HEADER_BYTES,
    PACKET_BYTES,
    PACKET_DTYPE,
    POINTS_PER_PACKET,
    Model,
)
from drivers.lidar.stats import ParserCounters

MAX_SPEED_DPS = 7200
SPAN_LOW = 0.5
SPAN_HIGH = 1.5
_SMALL_BATCH = 4  # below this many candidates a Python CRC is cheaper than numpy's setup
_OFFSETS = np.arange(PACKET_BYTES)

Records = npt.NDArray[np.void]
"""Packets as ``PACKET_DTYPE`` records (fields ``speed_dps``, ``points['distance_mm']``...)."""

EMPTY: Records = np.zeros(0, dtype=PACKET_DTYPE)


class PacketParser:
    """Feeds bytes, returns the intact packets among them; counts everything it drops.

    Args:
        model: sets the point rate the angle-span check expects.
    """

    def __init__(self, model: Model = Model.LD19, counters: ParserCounters | None = None) -> None:
        self.model = model
        self.counters = counters or ParserCounters()
        self._pending = b""
        self._in_sync = True
        self._per_span = (POINTS_PER_PACKET - 1) / model.points_per_s * 100.0

    def reset(self) -> None:
        """Forget a partial packet (the port was reopened)."""
        self.counters.skipped_bytes += len(self._pending)
        self._pending = b""

    def feed(self, data: bytes) -> Records:
        """Parse ``data`` after what came before; the packets it completed, in order."""
        counters = self.counters
        counters.bytes += len(data)
        buf = self._pending + data if self._pending else bytes(data)
        size = len(buf)
        if size < PACKET_BYTES:
            self._pending = buf
            return EMPTY
        last_complete = size - PACKET_BYTES
        candidates: list[int] = []
        find = buf.find
        at = find(HEADER_BYTES)
        while 0 <= at <= last_complete:
            candidates.append(at)
            at = find(HEADER_BYTES, at + 1)
        rows, crc_ok, plausible = self._check(buf, candidates)
        good = (crc_ok & plausible).tolist()
        pos = 0
        taken: list[int] = []
        for index, start in enumerate(candidates):
            if start < pos:
                continue  # 54 2C inside a packet already taken
            if good[index]:
                if start > pos:
                    self._skip(start - pos)
                self._in_sync = True
                taken.append(index)
                pos = start + PACKET_BYTES
            elif not crc_ok[index]:
                counters.crc_errors += 1  # search on from the byte after its header
                continue
            else:
                counters.implausible += 1
        tail = find(HEADER_BYTES, max(pos, last_complete + 1))
        if tail < 0:
            tail = size - 1 if buf[-1] == HEADER and size - 1 >= pos else size
        if tail > pos:
            self._skip(tail - pos)
        self._pending = buf[tail:]
        counters.packets += len(taken)
        if not taken:
            return EMPTY
        return rows[taken].view(PACKET_DTYPE).reshape(len(taken))

    def _skip(self, count: int) -> None:
        self.counters.skipped_bytes += count
        if self._in_sync:
            self.counters.resyncs += 1
            self._in_sync = False

    def _check(self, buf: bytes, candidates: list[int]
               ) -> tuple[npt.NDArray[np.uint8], npt.NDArray[np.bool_], npt.NDArray[np.bool_]]:
        """The candidates' 47 bytes as rows; which have a good CRC; which are plausible."""
        count = len(candidates)
        if count == 0:
            none = np.zeros(0, np.bool_)
            return np.zeros((0, PACKET_BYTES), np.uint8), none, none
        if count < _SMALL_BATCH:
            rows = np.frombuffer(b"".join(buf[s:s + PACKET_BYTES] for s in candidates),
                                 dtype=np.uint8).reshape(count, PACKET_BYTES)
            crc_ok = np.array([_crc_ok(buf, s) for s in candidates], dtype=np.bool_)
        else:
            array = np.frombuffer(buf, dtype=np.uint8)
            rows = array[np.asarray(candidates)[:, None] + _OFFSETS]
            crc_ok = crc8_rows(rows[:, :PACKET_BYTES - 1]) == rows[:, PACKET_BYTES - 1]
        records = rows.view(PACKET_DTYPE).reshape(count)
        speed = records["speed_dps"].astype(np.float64)
        start = records["start_cdeg"].astype(np.int64)
        end = records["end_cdeg"].astype(np.int64)
        span = (end - start + FULL_CIRCLE_CDEG) % FULL_CIRCLE_CDEG
        expected = speed * self._per_span
        plausible = ((speed >= 1) & (speed <= MAX_SPEED_DPS)
                     & (start < FULL_CIRCLE_CDEG) & (end < FULL_CIRCLE_CDEG)
                     & (span >= SPAN_LOW * expected) & (span <= SPAN_HIGH * expected))
        return rows, crc_ok, plausible


def _crc_ok(buf: bytes, start: int) -> bool:
    table = TABLE
    crc = 0
    for byte in buf[start:start + PACKET_BYTES - 1]:
        crc = table[crc ^ byte]
    return crc == buf[start + PACKET_BYTES - 1]
