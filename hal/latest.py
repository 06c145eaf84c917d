"""A holder for a device's newest reading that lets tasks wait for the next one.

Listeners are called with each value as it is published (no task wake-up); one that raises
is logged and keeps being called.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from typing import Generic, TypeVar

import structlog

log = structlog.get_logger(__name__)

T = TypeVar("T")


class LatestValue(Generic[T]):
    """Keeps the newest value; ``await next()`` waits for the one after the current."""

    def __init__(self) -> None:
        self._value: T | None = None
        self._waiters: list[asyncio.Future[T]] = []
        self._listeners: list[Callable[[T], object]] = []
        self.count = 0

    def latest(self) -> T | None:
        return self._value

    def publish(self, value: T) -> None:
        self._value = value
        self.count += 1
        for listener in self._listeners:
            try:
                listener(value)
            except Exception:
                log.exception("latest.listener_failed", listener=repr(listener))
        waiters, self._waiters = self._waiters, []
        for fut in waiters:
            if not fut.done():
                fut.set_result(value)

    def listen(self, callback: Callable[[T], object]) -> Callable[[], None]:
        """Call ``callback(value)`` on every publish from now on; returns the unsubscriber."""
        self._listeners = [*self._listeners, callback]

        def stop() -> None:
            self._listeners = [cb for cb in self._listeners if cb is not callback]

        return stop

    async def next(self) -> T:
        fut: asyncio.Future[T] = asyncio.get_running_loop().create_future()
        self._waiters.append(fut)
        return await fut

    def fail(self, exc: BaseException) -> None:
        """Wake every waiter with ``exc`` (the device went away)."""
        waiters, self._waiters = self._waiters, []
        for fut in waiters:
            if not fut.done():
                fut.set_exception(exc)
