"""A sleep whose timer resumes the task: same wake-up time, one callback, cancellable."""

from __future__ import annotations

import asyncio

import pytest

from hal.looptime.timer_sleep import timer_sleep
from sim import vclock


class TestTimerSleep:
    def test_it_wakes_when_asyncio_sleep_would(self) -> None:
        """Twenty 50 ms steps end at the same loop time as twenty asyncio.sleep(0.05)."""

        async def main() -> tuple[float, float]:
            loop = asyncio.get_running_loop()
            start = loop.time()
            for _ in range(20):
                await asyncio.sleep(0.05)
            by_sleep = loop.time() - start
            start = loop.time()
            for _ in range(20):
                await timer_sleep(0.05)
            return by_sleep, loop.time() - start

        by_sleep, by_timer = vclock.run(main())
        assert by_timer == pytest.approx(by_sleep)

    def test_a_wake_up_is_one_callback(self) -> None:
        """Nothing but the timer runs between the sleep and the task going on."""

        async def main() -> int:
            loop = asyncio.get_running_loop()
            calls = 0
            original = loop.call_soon

            def counting(*args: object, **kwargs: object) -> asyncio.Handle:
                nonlocal calls
                calls += 1
                return original(*args, **kwargs)  # type: ignore[arg-type]

            loop.call_soon = counting  # type: ignore[method-assign, assignment]
            for _ in range(10):
                await timer_sleep(0.01)
            loop.call_soon = original  # type: ignore[method-assign]
            return calls

        assert vclock.run(main()) == 0

    def test_cancelling_the_task_cancels_the_sleep(self) -> None:
        """The task sees CancelledError at the await, at once, and the timer never fires."""

        async def main() -> None:
            loop = asyncio.get_running_loop()
            woke: list[float] = []

            async def sleeper() -> None:
                try:
                    await timer_sleep(10.0)
                except asyncio.CancelledError:
                    woke.append(loop.time())
                    raise

            task = asyncio.create_task(sleeper())
            await asyncio.sleep(1.0)
            task.cancel()
            with pytest.raises(asyncio.CancelledError):
                await task
            assert woke == [pytest.approx(1.0)]
            await asyncio.sleep(20.0)  # the cancelled timer does not wake anything

        vclock.run(main())

    def test_it_works_on_a_plain_asyncio_loop(self) -> None:
        """Any asyncio loop: the real daemon's, not only the simulator's."""

        async def main() -> None:
            await timer_sleep(0.001)
            task = asyncio.create_task(timer_sleep_forever())
            await asyncio.sleep(0)
            task.cancel()
            with pytest.raises(asyncio.CancelledError):
                await task

        async def timer_sleep_forever() -> None:
            await timer_sleep(3600.0)

        asyncio.run(main())
