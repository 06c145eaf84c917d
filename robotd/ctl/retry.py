"""robotctl's retries of a connection the daemon could not take at once: bounded, backing off.

During a connect storm ``connect()`` fails with ``EAGAIN`` (the listen queue is full) and a full
daemon answers "too many clients"; both pass within moments (idle clients give way, the queue is
accepted), so robotctl tries again for up to ``RETRY_S`` before it says it cannot connect.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

RETRY_S = 1.0
FIRST_PAUSE_S = 0.01
MAX_PAUSE_S = 0.2


def wait_s(seconds: float) -> None:
    """Block this (one-shot, loop-less) process for ``seconds``."""
    threading.Event().wait(seconds)


class Backoff:
    """Pauses that double from ``FIRST_PAUSE_S`` to ``MAX_PAUSE_S``, within ``budget_s`` in
    all from the first attempt.

    Args:
        budget_s: time from the first attempt past which no attempt is made.
        pause: blocks for the given seconds (tests pass their own).
        clock: monotonic seconds.
    """

    def __init__(self, budget_s: float = RETRY_S, *, pause: Callable[[float], None] = wait_s,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self._pause = pause
        self._clock = clock
        self._deadline_s = clock() + budget_s
        self._next_s = FIRST_PAUSE_S
        self.attempts = 1

    @property
    def left_s(self) -> float:
        """Time left in the budget (0 when spent)."""
        return max(0.0, self._deadline_s - self._clock())

    def again(self) -> bool:
        """Pause before the next attempt; False (no pause) when the budget is spent."""
        left_s = self.left_s
        if left_s <= 0:
            return False
        self._pause(min(self._next_s, left_s))
        self._next_s = min(MAX_PAUSE_S, self._next_s * 2)
        self.attempts += 1
        return True
