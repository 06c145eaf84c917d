"""Ending a background task: cancel it and wait until it has finished."""

from __future__ import annotations

import asyncio
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
