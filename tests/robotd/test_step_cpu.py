"""The opt-in record of the loop's long steps, by CPU time and named by their task."""

from __future__ import annotations

import asyncio
import time

import pytest

from robotd.step_cpu import ENV, StepCpu


def _burn_cpu(cpu_s: float) -> None:
    end = time.thread_time() + cpu_s
    while time.thread_time() < end:
        pass


async def busy_parser() -> None:
    """One step that works, then waits in ``asyncio.sleep``."""
    _burn_cpu(0.02)
    await asyncio.sleep(0)


async def sleeper() -> None:
    """Steps that take wall time but no CPU."""
    await asyncio.sleep(0.03)


def _run(profiler: StepCpu, main: object) -> None:
    profiler.install()
    try:
        asyncio.run(main)  # type: ignore[arg-type]
    finally:
        profiler.uninstall()


class TestStepCpu:
    def test_a_step_over_the_threshold_is_named_by_its_task_and_where_it_waits(self) -> None:
        """The busy step is recorded under its coroutine and the coroutine it waits in."""
        profiler = StepCpu(5.0)

        async def main() -> None:
            await asyncio.gather(asyncio.create_task(busy_parser()),
                                 asyncio.create_task(sleeper()))

        _run(profiler, main())
        steps = profiler.figures()["steps"]
        assert list(steps) == ["busy_parser > sleep"]
        assert steps["busy_parser > sleep"]["count"] == 1
        assert steps["busy_parser > sleep"]["max_cpu_ms"] >= 5.0

    def test_a_step_that_waits_without_working_is_not_recorded(self) -> None:
        """Wall time spent off the CPU (a sleep, another process) is not the step's."""
        profiler = StepCpu(5.0)
        _run(profiler, sleeper())
        assert profiler.figures()["steps"] == {}

    def test_a_plain_callback_is_named_by_its_qualified_name(self) -> None:
        profiler = StepCpu(5.0)

        async def main() -> None:
            loop = asyncio.get_running_loop()
            done = loop.create_future()
            loop.call_soon(lambda: (_burn_cpu(0.02), done.set_result(None)))
            await done

        _run(profiler, main())
        (name,) = profiler.figures()["steps"]
        assert "<lambda>" in name

    def test_uninstall_restores_asyncio(self) -> None:
        original = asyncio.Handle._run
        profiler = StepCpu(1.0)
        profiler.install()
        profiler.install()  # twice is once
        assert asyncio.Handle._run is not original
        profiler.uninstall()
        assert asyncio.Handle._run is original


class TestFromEnv:
    def test_unset_or_empty_means_off(self) -> None:
        assert StepCpu.from_env({}) is None
        assert StepCpu.from_env({ENV: ""}) is None

    def test_a_number_is_the_threshold(self) -> None:
        profiler = StepCpu.from_env({ENV: "2.5"})
        assert profiler is not None
        assert profiler.threshold_ms == 2.5

    @pytest.mark.parametrize("raw", ["fast", "0", "-1"])
    def test_anything_else_is_a_clear_error(self, raw: str) -> None:
        with pytest.raises(ValueError, match=ENV):
            StepCpu.from_env({ENV: raw})
