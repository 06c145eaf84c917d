"""DeadlineSleeper: precise wake-ups on a real Linux loop, plain sleeps in virtual time."""

from __future__ import annotations

import asyncio
import contextlib
import sys

import pytest

from hal.looptime.deadline import DeadlineSleeper
from sim import vclock

linux_only = pytest.mark.skipif(sys.platform != "linux", reason="timerfd is Linux's")


class TestOnARealLoop:
    @linux_only
    async def test_it_uses_a_timerfd_and_never_returns_before_the_deadline(self) -> None:
        """Each sleep ends at or after its deadline on the loop's clock (asyncio's own)."""
        loop = asyncio.get_running_loop()
        sleeper = DeadlineSleeper()
        try:
            assert sleeper.precise
            deadline = loop.time()
            for _ in range(5):
                deadline += 0.003
                await sleeper.sleep_until(deadline)
                assert loop.time() >= deadline
        finally:
            sleeper.close()

    async def test_a_deadline_in_the_past_returns_at_once(self) -> None:
        """An overrun loop asks for a time already gone: it yields and goes on."""
        loop = asyncio.get_running_loop()
        sleeper = DeadlineSleeper()
        try:
            await asyncio.wait_for(sleeper.sleep_until(loop.time() - 1.0), 1.0)
        finally:
            sleeper.close()

    @linux_only
    async def test_a_cancelled_sleep_leaves_the_sleeper_usable(self) -> None:
        """Cancelling a task in its sleep takes the timer off the loop; the next sleep works."""
        loop = asyncio.get_running_loop()
        sleeper = DeadlineSleeper()
        try:
            task = asyncio.create_task(sleeper.sleep_until(loop.time() + 60.0))
            await asyncio.sleep(0.01)
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await task
            deadline = loop.time() + 0.005
            await asyncio.wait_for(sleeper.sleep_until(deadline), 5.0)
            assert loop.time() >= deadline
        finally:
            sleeper.close()

    async def test_after_close_it_falls_back_to_asyncio_sleep(self) -> None:
        loop = asyncio.get_running_loop()
        sleeper = DeadlineSleeper()
        sleeper.close()
        assert not sleeper.precise
        deadline = loop.time() + 0.002
        await sleeper.sleep_until(deadline)
        assert loop.time() >= deadline - 0.001  # asyncio's own timer granularity


class TestInVirtualTime:
    def test_the_virtual_clock_governs_and_no_timerfd_is_used(self) -> None:
        """The simulator's clock is not the monotonic clock: sleeps are virtual and exact."""

        async def main() -> tuple[bool, float, float]:
            loop = asyncio.get_running_loop()
            sleeper = DeadlineSleeper()
            precise = sleeper.precise
            start = loop.time()
            await sleeper.sleep_until(start + 3600.0)
            sleeper.close()
            return precise, start, loop.time()

        precise, start, end = vclock.run(main())
        assert not precise
        assert end - start == pytest.approx(3600.0)
