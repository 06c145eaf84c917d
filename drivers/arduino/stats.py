"""Counters and round-trip times of the Arduino link, for ``status()`` and ``link_stats()``."""

from __future__ import annotations

import collections
from dataclasses import dataclass, field
from typing import Any

from hal.readings import LinkStats

RTT_WINDOW = 1000


def percentile(samples: list[float], fraction: float) -> float | None:
    """Nearest-rank percentile (``fraction`` in 0-1) of unsorted samples; None when empty."""
    if not samples:
        return None
    ordered = sorted(samples)
    rank = max(0, min(len(ordered) - 1, round(fraction * len(ordered) + 0.5) - 1))
    return ordered[rank]


@dataclass
class LinkCounters:
    """What happened on the link since the driver started (all connections together)."""

    sent: int = 0  # distinct commands transmitted (resends not counted)
    acked: int = 0
    resent: int = 0
    lost: int = 0
    superseded: int = 0
    nak: int = 0
    crc_errors: int = 0  # received lines damaged on the wire
    unparsed: int = 0  # intact lines of no known shape
    unknown_telemetry: int = 0
    bad_telemetry: int = 0
    overlong: int = 0
    stale_replies: int = 0  # replies to a SEQ no longer in flight
    reconnects: int = 0
    mcu_resets: int = 0
    rtt_s: collections.deque[float] = field(
        default_factory=lambda: collections.deque(maxlen=RTT_WINDOW))

    def rtt_ms(self, fraction: float) -> float | None:
        value = percentile(list(self.rtt_s), fraction)
        return None if value is None else round(value * 1000.0, 3)

    def snapshot(self, *, connected: bool, dropped: int, firmware: str | None) -> LinkStats:
        return LinkStats(
            connected=connected, sent=self.sent, acked=self.acked, resent=self.resent,
            lost=self.lost, dropped=dropped, crc_errors=self.crc_errors, nak=self.nak,
            reconnects=self.reconnects, rtt_p50_ms=self.rtt_ms(0.5),
            rtt_p99_ms=self.rtt_ms(0.99), firmware=firmware,
        )

    def extras(self) -> dict[str, Any]:
        """Figures beyond ``LinkStats`` that a technician may want."""
        return {
            "superseded": self.superseded, "unparsed": self.unparsed,
            "unknown_telemetry": self.unknown_telemetry, "bad_telemetry": self.bad_telemetry,
            "overlong": self.overlong, "stale_replies": self.stale_replies,
            "mcu_resets": self.mcu_resets,
        }
