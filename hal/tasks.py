"""Background tasks: ending one (cancel, then wait), and keeping a connection up (reconnect)."""

from __future__ import annotations

import asyncio
from collections.abc import Awaitable, Callable
from typing import Any


async def cancel_and_wait(task: asyncio.Task[Any] | None) -> None:
    """Cancel ``task`` (None: nothing to do) and wait for it to finish.

    The task's own ``CancelledError`` is swallowed; the caller's is not: when the task calling
    this is itself being cancelled while it waits, the cancellation goes on up. An exception
    the task ended with is raised here, as awaiting the task would.
    """
    if task is None:
        return
    task.cancel()
    try:
        await task
    except asyncio.CancelledError:
        current = asyncio.current_task()
        if current is not None and current.cancelling():
            raise


async def reconnect_forever(connect_once: Callable[[], Awaitable[str | None]], *,
                            first: asyncio.Future[str | None] | None,
                            min_s: float, max_s: float,
                            on_wait: Callable[[float], None],
                            running: Callable[[], bool] = lambda: True) -> None:
    """Connect, and when a connection ends connect again, with exponential backoff.

    Args:
        connect_once: one connection from open to loss; None when it got up, else why not.
        first: told the outcome of the first attempt (a start-up waits on it); when that
            attempt failed the loop ends there, and the caller reports why.
        min_s: the first wait, and the wait after a connection that got up.
        max_s: the backoff's cap.
        on_wait: told each wait before it (a log line with the port).
        running: the loop goes on while this is true.
    """
    backoff_s = min_s
    while running():
        error = await connect_once()
        if error is None:
            backoff_s = min_s
        if first is not None and not first.done():
            first.set_result(error)
            if error is not None:
                return
        on_wait(backoff_s)
        await asyncio.sleep(backoff_s)
        backoff_s = min(backoff_s * 2, max_s)
