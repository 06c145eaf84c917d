"""A holder for a device's newest reading that lets tasks wait for the next one."""

from __future__ import annotations

import asyncio
from typing import Generic, TypeVar

T = TypeVar("T")


class LatestValue(Generic[T]):
    """Keeps the newest value; ``await next()`` waits for the one after the current."""

    def __init__(self) -> None:
        self._value: T | None = None
        self._waiters: list[asyncio.Future[T]] = []
        self.count = 0

    def latest(self) -> T | None:
        return self._value

    def publish(self, value: T) -> None:
        self._value = value
        self.count += 1
        waiters, self._waiters = self._waiters, []
        for fut in waiters:
            if not fut.done():
                fut.set_result(value)

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
