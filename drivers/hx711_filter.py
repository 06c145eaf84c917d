"""The HX711 driver's filter (seed 000 section 11): a code far from the median of the recent
ones is rejected, the accepted ones are averaged over a moving window."""

from __future__ import annotations

from collections import deque


class OutlierFilter:
    """Median-based rejection followed by a moving average of the accepted codes."""

    def __init__(self, median_window: int = 5, average_window: int = 8,
                 outlier_counts: float = 100_000) -> None:
        self._recent: deque[int] = deque(maxlen=median_window)
        self._accepted: deque[int] = deque(maxlen=average_window)
        self.outlier_counts = outlier_counts

    @property
    def window(self) -> int:
        return self._accepted.maxlen or 1

    def resize(self, average_window: int) -> None:
        self._accepted = deque(self._accepted, maxlen=average_window)

    def add(self, code: int) -> bool:
        """Feed a code; False when it was rejected as an outlier."""
        # Every code enters the median window, so a real step change is accepted once it holds
        # for half the window.
        recent = self._recent
        recent.append(code)
        if len(recent) >= 3 and abs(code - _median(recent)) > self.outlier_counts:
            return False
        self._accepted.append(code)
        return True

    def average(self) -> float | None:
        return sum(self._accepted) / len(self._accepted) if self._accepted else None

    def robust_average(self) -> float | None:
        """Mean of the accepted codes near their median: a spike that got in (the first codes
        after start-up have no median to be checked against) does not move a tare."""
        if not self._accepted:
            return None
        median = _median(self._accepted)
        near = [c for c in self._accepted if abs(c - median) <= self.outlier_counts]
        return sum(near) / len(near)

    def clear(self) -> None:
        """Restart the moving average; the median history stays, so the next code is still
        checked against the recent ones."""
        self._accepted.clear()


def _median(codes: deque[int]) -> int | float:  # int | float: as statistics.median gives
    """``statistics.median`` of a few codes, without its conversions (once per read)."""
    ordered = sorted(codes)
    mid = len(ordered) // 2
    return ordered[mid] if len(ordered) % 2 else (ordered[mid - 1] + ordered[mid]) / 2
