"""Waiting for the HX711's data-ready (DOUT low) on a fixed poll grid, by polling or by edge.

DOUT is read at once, then on a grid of ``POLL_S`` steps from that instant, until it reads
low or the deadline has passed: a conversion is read on the first grid instant after it is
ready. Lines that also offer ``hal.ports.DoutAlert`` let the task sleep until DOUT falls (or
until the deadline) and then read on the first grid instant at or after that moment: the very
instants polling reads on, without the wake-ups in between (up to 500 a second). The alert is
only a hint: DOUT is still read on the grid, and a read that finds it high waits again.

The grid is kept as sums of ``POLL_S`` rather than taken from each wake-up's clock (as
``asyncio.sleep`` would), so the instants do not depend on which other timers the loop
happened to run in the same turn, and polling and waiting for the edge give the same ones.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable

from hal.ports import Hx711Lines

POLL_S = 0.002


async def wait_dout_low(lines: Hx711Lines, timeout_s: float, poll_s: float = POLL_S) -> bool:
    """True once DOUT reads low; False when it still reads high at ``timeout_s`` or later."""
    loop = asyncio.get_running_loop()
    due_s = loop.time()
    deadline_s = due_s + timeout_s
    # getattr, not isinstance: a runtime Protocol check costs more than a poll.
    on_dout_low = getattr(lines, "on_dout_low", None)
    while lines.read_dout():  # DOUT high: conversion not ready
        if loop.time() >= deadline_s:
            return False
        due_s += poll_s
        if on_dout_low is not None:
            woke_s = await _dout_low_or_deadline(loop, on_dout_low, deadline_s)
            while due_s < woke_s:  # the grid instants in between would have read it high
                due_s += poll_s
        await _sleep_until(loop, due_s)
    return True


async def _dout_low_or_deadline(loop: asyncio.AbstractEventLoop,
                                on_dout_low: Callable[[Callable[[], None]], Callable[[], None]],
                                deadline_s: float) -> float:
    """Sleep until the lines report DOUT low or until ``deadline_s``; the loop time then."""
    woke: asyncio.Future[None] = loop.create_future()

    def wake() -> None:
        if not woke.done():
            woke.set_result(None)

    cancel = on_dout_low(wake)
    timer = loop.call_at(deadline_s, wake)
    try:
        await woke
    finally:
        cancel()
        timer.cancel()
    return loop.time()


def _set_unless_done(future: asyncio.Future[None]) -> None:
    if not future.done():
        future.set_result(None)


async def _sleep_until(loop: asyncio.AbstractEventLoop, when_s: float) -> None:
    """``asyncio.sleep`` to an absolute loop time (the same two callbacks: timer, task)."""
    future: asyncio.Future[None] = loop.create_future()
    timer = loop.call_at(when_s, _set_unless_done, future)
    try:
        await future
    finally:
        timer.cancel()
