"""A sensor facet of the Arduino link: the newest reading, listeners, and the next reading."""

from __future__ import annotations

from collections.abc import Callable, Coroutine
from typing import Any, Generic, TypeVar

from hal.latest import LatestValue

T = TypeVar("T")


class Feed(Generic[T]):
    """A sensor facet of the link: newest reading and the next one (fails on link down)."""

    def __init__(self) -> None:
        self._latest: LatestValue[T] = LatestValue()
        self.publish: Callable[[T], None] = self._latest.publish  # no frame of our own

    def latest(self) -> T | None:
        return self._latest.latest()

    def listen(self, callback: Callable[[T], object]) -> Callable[[], None]:
        """Call ``callback(reading)`` as each reading arrives; returns the unsubscriber."""
        return self._latest.listen(callback)

    def next_reading(self) -> Coroutine[Any, Any, T]:
        """Awaitable: the next reading (LinkDown when the link goes down first)."""
        return self._latest.next()  # its coroutine itself: one frame less per reading

    def fail(self, exc: BaseException) -> None:
        self._latest.fail(exc)
