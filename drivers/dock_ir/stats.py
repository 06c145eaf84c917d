"""Counters of one receiver's decoder: what was decoded and every way a frame was lost."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

ERROR_COUNTERS = ("glitches", "half_codes", "collisions", "dropped_edges")
"""The ways a frame is lost (an unknown code is decoded right: it is not among them)."""


@dataclass(slots=True)
class DecodeStats:
    """What one receiver's decoder saw since it started. Nothing here ever raises."""

    edges: int = 0
    codes: int = 0  # frames decoded into a code, known or not
    unknown_codes: int = 0  # decoded right, but not in the code table
    glitches: int = 0  # a pulse out of tolerance at a frame's start, or a noise spike
    half_codes: int = 0  # a frame cut short by a long gap before its 8th bit
    collisions: int = 0  # mark and space widths that disagree mid-frame, or a frame too long
    dropped_edges: int = 0  # the same level twice in a row: an edge was lost, and the frame
    recovered_edges: int = 0  # a lost mark start, the frame read all the same
    clock_steps: int = 0  # an edge stamped before the one before it

    @property
    def errors(self) -> int:
        return self.glitches + self.half_codes + self.collisions + self.dropped_edges

    @property
    def error_rate(self) -> float | None:
        """Lost frames per frame attempted (decoded + lost); None before any."""
        attempts = self.codes + self.errors
        return self.errors / attempts if attempts else None

    def add(self, other: DecodeStats) -> None:
        for name, value in asdict(other).items():
            setattr(self, name, getattr(self, name) + value)

    def as_dict(self) -> dict[str, Any]:
        rate = self.error_rate
        return {**asdict(self), "error_rate": None if rate is None else round(rate, 4)}


def total(stats: list[DecodeStats]) -> DecodeStats:
    """The counters of several receivers added up."""
    out = DecodeStats()
    for one in stats:
        out.add(one)
    return out
