"""timer_chain: periodic work as timer callbacks, ended by None, an exception or cancelling."""

from __future__ import annotations

import asyncio
import contextlib

import pytest

from hal.looptime.timer_chain import timer_chain
from sim import vclock


class TestTimerChain:
    def test_steps_run_at_the_delays_they_return_until_one_returns_none(self) -> None:
        async def main() -> list[float]:
            loop = asyncio.get_running_loop()
            start = loop.time()
            times: list[float] = []

            def step() -> float | None:
                times.append(loop.time() - start)
                return None if len(times) == 4 else 0.5 * len(times)

            await timer_chain(step, first_delay_s=1.0)
            return times

        assert vclock.run(main()) == pytest.approx([1.0, 1.5, 2.5, 4.0])

    def test_without_a_first_delay_the_first_step_runs_at_once(self) -> None:
        async def main() -> float:
            loop = asyncio.get_running_loop()
            start = loop.time()
            when: list[float] = []

            def step() -> None:
                when.append(loop.time() - start)

            await timer_chain(step)
            return when[0]

        assert vclock.run(main()) == 0.0

    def test_an_exception_in_a_step_ends_the_chain_and_is_raised(self) -> None:
        calls = []

        def step() -> float:
            calls.append(1)
            if len(calls) == 3:
                msg = "encoder stuck"
                raise RuntimeError(msg)
            return 0.1

        with pytest.raises(RuntimeError, match="encoder stuck"):
            vclock.run(timer_chain(step))
        assert len(calls) == 3

    def test_cancelling_the_task_stops_the_steps(self) -> None:
        async def main() -> int:
            calls: list[int] = []

            def step() -> float:
                calls.append(1)
                return 0.1

            task = asyncio.create_task(timer_chain(step))
            await asyncio.sleep(0.35)
            task.cancel()
            await asyncio.gather(task, return_exceptions=True)
            seen = len(calls)
            await asyncio.sleep(1.0)
            assert len(calls) == seen
            return seen

        assert vclock.run(main()) == 4


class TestOnAGrid:
    def test_ticks_land_on_the_grid_of_the_period(self) -> None:
        """Ticks at 0.1, 0.2, 0.3 ... of loop time, the first one period after the start."""
        from hal.looptime.timer_chain import on_a_grid

        async def main() -> list[float]:
            loop = asyncio.get_running_loop()
            start = loop.time()
            times: list[float] = []

            def tick() -> None:
                times.append(round(loop.time() - start, 6))

            task = asyncio.create_task(on_a_grid(tick, 0.1))
            await asyncio.sleep(0.55)
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await task
            return times

        assert vclock.run(main()) == [0.1, 0.2, 0.3, 0.4, 0.5]
