"""A sleep whose timer resumes the sleeping task itself.

``await asyncio.sleep(d)`` costs two loop callbacks per wake-up: the timer sets a future,
the future schedules the task. ``await timer_sleep(d)`` hands the task's wake-up to the
timer directly (the task protocol for future-like objects: ``_asyncio_future_blocking``,
``add_done_callback``, ``result``, ``cancel``), so a loop that paces itself at 20 Hz costs
one callback per step. Same wake-up time as ``asyncio.sleep`` (``call_later`` from the same
moment); cancelling the task cancels the timer and raises CancelledError at the ``await``.
Await it directly: it is no Future for ``wait_for`` or ``gather``.
"""

from __future__ import annotations

import asyncio
import contextvars
from collections.abc import Callable, Generator
from typing import Any


class _TimerWait:
    """What the task waits on: a timer that calls the task's wake-up with this object."""

    __slots__ = ("_asyncio_future_blocking", "_cancelled", "_context", "_delay_s", "_loop",
                 "_timer", "_wakeup")

    def __init__(self, loop: asyncio.AbstractEventLoop, delay_s: float) -> None:
        self._loop = loop
        self._delay_s = delay_s
        self._asyncio_future_blocking = False
        self._cancelled = False
        self._timer: asyncio.TimerHandle | None = None
        self._wakeup: Callable[[Any], object] | None = None
        self._context: contextvars.Context | None = None

    def __await__(self) -> Generator[Any, None, None]:
        self._asyncio_future_blocking = True
        yield self  # the task calls add_done_callback with its wake-up
        if self._cancelled:
            raise asyncio.CancelledError

    def get_loop(self) -> asyncio.AbstractEventLoop:
        return self._loop

    def add_done_callback(self, fn: Callable[[Any], object], *,
                          context: contextvars.Context | None = None) -> None:
        self._wakeup, self._context = fn, context
        self._timer = self._loop.call_later(self._delay_s, fn, self, context=context)

    def result(self) -> None:
        if self._cancelled:
            raise asyncio.CancelledError

    def cancel(self, msg: Any = None) -> bool:
        if self._cancelled or self._timer is None or self._wakeup is None:
            return False
        self._cancelled = True
        self._timer.cancel()
        self._loop.call_soon(self._wakeup, self, context=self._context)
        return True


def timer_sleep(delay_s: float) -> _TimerWait:
    """Awaitable: resume after ``delay_s`` of the running loop's time (one loop callback)."""
    return _TimerWait(asyncio.get_running_loop(), delay_s)
