"""Connections past ``max_clients``: the waiting room, first come first served.

When every place is held and nobody can give way, a newcomer is not turned away at once: up to
``wait_max`` of them sit in the waiting room, each with ``wait_s`` to send its first request and
get the next place that frees up, in the order they came (a connect storm's clients come and
go within milliseconds, so a place frees up soon). An ``estop`` among them is served the moment
it is read, ahead of everyone. This module keeps the books; the server does the I/O.
"""

from __future__ import annotations

import asyncio
from collections import deque
from dataclasses import dataclass


@dataclass(slots=True, eq=False)
class Seat:
    """One connection in the waiting room; ``place`` resolves when it is given one."""

    since_s: float
    place: asyncio.Future[None] | None = None


class WaitingRoom:
    """The seats past the limit and their queue for places (bookkeeping only: no I/O)."""

    def __init__(self, wait_max: int) -> None:
        self.wait_max = wait_max
        self.seats: list[Seat] = []
        self._queue: deque[Seat] = deque()

    def __len__(self) -> int:
        return len(self.seats)

    @property
    def queued(self) -> int:
        """Seats waiting for a place (having sent their first request)."""
        return len(self._queue)

    def seat(self, now_s: float) -> Seat | None:
        """A seat for a newcomer, or None when the room is full."""
        if len(self.seats) >= self.wait_max:
            return None
        seat = Seat(now_s)
        self.seats.append(seat)
        return seat

    def leave(self, seat: Seat) -> None:
        """The seat is given up (it got a place, or it is refused); twice is harmless."""
        if seat in self.seats:
            self.seats.remove(seat)
        if seat in self._queue:
            self._queue.remove(seat)
        if seat.place is not None and not seat.place.done():
            seat.place.cancel()

    def queue(self, seat: Seat) -> asyncio.Future[None]:
        """The seat's turn for a place: done when ``hand_over`` gives it one."""
        seat.place = asyncio.get_running_loop().create_future()
        self._queue.append(seat)
        return seat.place

    def hand_over(self, places: int) -> int:
        """Give up to ``places`` free places to the longest waiting; how many were given."""
        given = 0
        while given < places and self._queue:
            seat = self._queue.popleft()
            if seat.place is not None and not seat.place.done():
                seat.place.set_result(None)
                given += 1
        return given
