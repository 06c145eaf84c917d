"""Waiting for the HX711's data-ready (DOUT low) on a fixed poll grid, by polling or by edge.

DOUT is read first at ``from_s`` (by default at once), then on a grid of ``POLL_S`` steps from
that instant, until it reads low or the deadline has passed: a conversion is read on the
first grid instant after it is ready. Lines that also offer ``hal.ports.DoutAlert`` let the
task sleep until DOUT falls (or until the deadline) and then read on the first grid instant at
or after that moment: the very instants polling reads on, without the wake-ups in between (up
to 500 a second). The alert is only a hint: DOUT is still read on the grid, and a read that
finds it high waits again.

The grid is kept as sums of ``POLL_S`` rather than taken from each wake-up's clock (as
``asyncio.sleep`` would), so the instants do not depend on which other timers the loop
happened to run in the same turn, and polling and waiting for the edge give the same ones.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable

from hal.ports import Hx711Lines

POLL_S = 0.002


async def wait_dout_low(lines: Hx711Lines, timeout_s: float, poll_s: float = POLL_S, *,
                        from_s: float | None = None) -> bool:
    """True once DOUT reads low; False when it still reads high at ``timeout_s`` or later.

    DOUT is first read at ``from_s`` (a loop time not before now; None: now), and the
    timeout counts from there, as if the wait had been started then: the reader can start
    waiting as soon as it has read a conversion, without a wake-up at ``from_s``.
    """
    loop = asyncio.get_running_loop()
    now_s = loop.time()
    due_s = now_s if from_s is None else from_s
    deadline_s = due_s + timeout_s
    # getattr, not isinstance: a runtime Protocol check costs more than a poll.
    on_dout_low = getattr(lines, "on_dout_low", None)
    if due_s > now_s:
        if on_dout_low is None:
            await _sleep_until(loop, due_s)
        else:  # DOUT low by ``due_s`` reads low then; later, on the grid after it falls
            due_s = await _grid_after_dout_low(loop, on_dout_low, deadline_s, due_s, poll_s)
    while lines.read_dout():  # DOUT high: conversion not ready
        # This read is at ``due_s`` (a virtual clock that jumped there may read a unit in the
        # last place short of it) or later when the loop ran late.
        if max(loop.time(), due_s) >= deadline_s:
            return False
        due_s += poll_s
        if on_dout_low is None:
            await _sleep_until(loop, due_s)
        else:  # the grid instants before the edge would have read it high
            due_s = await _grid_after_dout_low(loop, on_dout_low, deadline_s, due_s, poll_s)
    return True


async def _grid_after_dout_low(loop: asyncio.AbstractEventLoop,
                               on_dout_low: Callable[[Callable[[], None]], Callable[[], None]],
                               deadline_s: float, due_s: float, poll_s: float) -> float:
    """Sleep until the first grid instant (``due_s`` + k ``poll_s``, k >= 0) at or after the
    moment the lines report DOUT low or ``deadline_s`` passes; returns that instant.

    The alert's callback sets the timer for the grid instant itself, so the task wakes once.
    """
    woke: asyncio.Future[None] = loop.create_future()
    grid_timer: asyncio.TimerHandle | None = None

    def wake() -> None:
        nonlocal due_s, grid_timer
        if grid_timer is not None or woke.done():
            return  # the alert and the deadline both came
        cancel()
        deadline_timer.cancel()
        now_s = loop.time()
        while due_s < now_s:
            due_s += poll_s
        grid_timer = loop.call_at(due_s, _set_unless_done, woke)

    cancel = on_dout_low(wake)
    deadline_timer = loop.call_at(deadline_s, wake)
    try:
        await woke
    finally:
        cancel()
        deadline_timer.cancel()
        if grid_timer is not None:
            grid_timer.cancel()
    return due_s


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
