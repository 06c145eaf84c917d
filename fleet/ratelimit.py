"""Failed authentications counted per client address: a brute-forcing client gets 429.

The counts live in this process's memory. Several server processes behind a load balancer
each count on their own, so a client spread over them gets up to ``processes x limit``
failures a minute; the limit is there to make guessing slow and cheap to refuse, and a
256-bit token cannot be guessed anyway. Clients behind one NAT or proxy share an address
and so share the limit.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable

WINDOW_S = 60.0
# Addresses remembered at most; past this the oldest are forgotten (memory stays bounded).
MAX_ADDRESSES = 10_000


class FailureLimiter:
    """Args:
        max_failures: failed authentications per ``window_s`` an address may make; 0 turns
            the limit off.
        clock: loop time in seconds (``loop.time``).
    """

    def __init__(self, max_failures: int, clock: Callable[[], float],
                 window_s: float = WINDOW_S) -> None:
        self.max_failures = max_failures
        self.window_s = window_s
        self._clock = clock
        self._failures: dict[str, deque[float]] = {}
        self.refused = 0

    def retry_after_s(self, address: str) -> int:
        """0 when the address may try; otherwise how many seconds until it may again."""
        if self.max_failures <= 0:
            return 0
        times = self._failures.get(address)
        if times is None:
            return 0
        now = self._clock()
        while times and now - times[0] >= self.window_s:
            times.popleft()
        if not times:
            del self._failures[address]
            return 0
        if len(times) < self.max_failures:
            return 0
        self.refused += 1
        return max(1, math.ceil(self.window_s - (now - times[0])))

    def failed(self, address: str) -> None:
        if self.max_failures <= 0:
            return
        times = self._failures.pop(address, None)
        if times is None:
            times = deque(maxlen=self.max_failures)
            if len(self._failures) >= MAX_ADDRESSES:
                del self._failures[next(iter(self._failures))]
        times.append(self._clock())
        self._failures[address] = times  # re-inserted: the dict stays oldest-first
