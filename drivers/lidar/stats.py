"""Counters of the LD19 link, for ``status()``, ``robotd probe lidar`` and ``robotctl sensors``.

Kept in plain dataclasses that the parser, the scan assembler and the device each update;
``snapshot()`` flattens them into one dict of figures a technician can read.
"""

from __future__ import annotations

import collections
from dataclasses import asdict, dataclass, field
from typing import Any

SCAN_RATE_WINDOW = 20  # scans whose times give the scan rate


@dataclass
class ParserCounters:
    """What the packet parser saw since it started (every connection together)."""

    bytes: int = 0
    packets: int = 0
    crc_errors: int = 0  # candidate headers whose CRC-8 failed
    implausible: int = 0  # intact CRC, impossible speed, angle or span
    resyncs: int = 0  # times the parser lost the packet boundary and searched for it
    skipped_bytes: int = 0  # bytes dropped outside any accepted packet


@dataclass
class ScanCounters:
    """What the scan assembler made of the packets."""

    scans: int = 0
    points_per_scan: int = 0  # of the last scan
    valid_points: int = 0  # of the last scan
    last_gap_ms: int = 0  # sensor time between the last two packets (wraps at 30000)
    max_gap_ms: int = 0
    lost_packets: int = 0  # estimated from the sensor timestamps' gaps
    scan_times_s: collections.deque[float] = field(
        default_factory=lambda: collections.deque(maxlen=SCAN_RATE_WINDOW))

    @property
    def scan_rate_hz(self) -> float:
        """Scans per second over the last few scans (0 before two)."""
        times = self.scan_times_s
        if len(times) < 2 or times[-1] <= times[0]:
            return 0.0
        return (len(times) - 1) / (times[-1] - times[0])


def snapshot(parser: ParserCounters, scans: ScanCounters) -> dict[str, Any]:
    """Both sets of counters as one flat dict (rates rounded for people)."""
    figures = asdict(parser)
    figures.update({k: v for k, v in asdict(scans).items() if k != "scan_times_s"})
    figures["scan_rate_hz"] = round(scans.scan_rate_hz, 3)
    return figures
