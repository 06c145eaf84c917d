"""hold_loop_time holds a loop's clock when the loop offers hold_time(), and does nothing on a
plain loop."""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Iterator

from fleet.timehold import hold_loop_time


class HoldingLoop(asyncio.SelectorEventLoop):
    """A loop that counts the holds under way, as the simulator's virtual-time loop does."""

    def __init__(self) -> None:
        super().__init__()
        self.holds = 0
        self.seen: list[int] = []

    @contextlib.contextmanager
    def hold_time(self) -> Iterator[None]:
        self.holds += 1
        try:
            yield
        finally:
            self.holds -= 1


def test_the_loops_clock_is_held_inside_and_released_after() -> None:
    loop = HoldingLoop()

    async def work() -> None:
        with hold_loop_time():
            loop.seen.append(loop.holds)
            with hold_loop_time():
                loop.seen.append(loop.holds)
        loop.seen.append(loop.holds)

    try:
        loop.run_until_complete(work())
    finally:
        loop.close()
    assert loop.seen == [1, 2, 0]


def test_released_when_the_work_fails() -> None:
    loop = HoldingLoop()

    async def failing() -> None:
        with hold_loop_time():
            raise KeyError("x")

    try:
        with contextlib.suppress(KeyError):
            loop.run_until_complete(failing())
        assert loop.holds == 0
    finally:
        loop.close()


async def test_on_a_plain_loop_it_does_nothing_and_can_be_nested() -> None:
    with hold_loop_time(), hold_loop_time():
        await asyncio.sleep(0)
