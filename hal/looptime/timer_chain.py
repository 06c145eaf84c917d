"""Periodic work as a chain of timer callbacks, each setting the next.

A task that sleeps between two pieces of work costs two loop turns per wake-up (the timer
sets the sleep's future, then the task runs); a timer callback costs one. The simulator turns
its loop hundreds of times per virtual second, so its heartbeats, telemetry, samples and
watch ticks run this way.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable


async def timer_chain(step: Callable[[], float | None],
                      first_delay_s: float | None = None) -> None:
    """Call ``step()`` now (or after ``first_delay_s``), then again after each delay it
    returns, until it returns None (the chain ends and this returns) or the task is cancelled.
    An exception from ``step`` ends the chain and is raised here, as a failing loop would."""
    loop = asyncio.get_running_loop()
    done: asyncio.Future[None] = loop.create_future()
    timer: asyncio.TimerHandle | None = None

    def run() -> None:
        nonlocal timer
        try:
            delay_s = step()
        except Exception as exc:
            done.set_exception(exc)
            return
        if delay_s is None:
            done.set_result(None)
        else:
            timer = loop.call_later(delay_s, run)

    if first_delay_s is None:
        run()
    else:
        timer = loop.call_later(first_delay_s, run)
    try:
        await done
    finally:
        if timer is not None:
            timer.cancel()


async def on_a_grid(tick: Callable[[], None], period_s: float) -> None:
    """Call ``tick()`` every ``period_s`` of loop time, the first one period from now, on a
    fixed grid (a late call does not push the next ones back), until cancelled."""
    loop = asyncio.get_running_loop()
    deadline = loop.time() + period_s

    def step() -> float:
        nonlocal deadline
        tick()
        deadline += period_s
        return max(0.0, deadline - loop.time())

    await timer_chain(step, max(0.0, deadline - loop.time()))
