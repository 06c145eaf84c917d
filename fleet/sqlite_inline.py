"""An aiosqlite connection that runs each call on the event loop's own thread.

aiosqlite hands every call (execute, fetch, commit...) to a worker thread and wakes the loop
when it is done: two thread switches and a loop turn per call. A single-process server on a
local SQLite file (``robotd-fleet serve --sqlite-inline``; the simulator runs its in-process
server so), where each statement takes microseconds, spends more on those hand-offs than on
SQL. ``InlineConnection`` keeps aiosqlite's
API, so SQLAlchemy's aiosqlite dialect and all the fleet code run unchanged, but the calls
complete at once and their futures are already done when awaited.

Only for a single-process server whose writes are serialized in the process (``Database``
does this with its write lock): a call that had to wait for a SQLite lock would block the loop.
"""

from __future__ import annotations

import asyncio
import queue
import sqlite3
from collections.abc import Callable, Generator
from typing import Any

import aiosqlite

Call = tuple[asyncio.Future[Any] | None, Callable[[], Any]]


class _RunAtOnce(queue.SimpleQueue[Call]):
    """Stands in for aiosqlite's queue to its worker thread: runs each call when it is queued."""

    def put_nowait(self, item: Call) -> None:
        future, function = item
        try:
            result = function()
        except BaseException as exc:  # handed to the awaiting caller, as aiosqlite does
            if future is not None and not future.done():
                future.set_exception(exc)
            return
        if future is not None and not future.done():
            future.set_result(result)

    def put(self, item: Call, block: bool = True, timeout: float | None = None) -> None:
        self.put_nowait(item)


class InlineConnection(aiosqlite.Connection):
    """``aiosqlite.Connection`` without its worker thread (see the module docstring)."""

    def __init__(self, connector: Callable[[], sqlite3.Connection],
                 iter_chunk_size: int = 64) -> None:
        super().__init__(connector, iter_chunk_size)
        self._tx = _RunAtOnce()

    def __await__(self) -> Generator[Any, None, aiosqlite.Connection]:
        return self._connect().__await__()


def inline_connect(database: str, **kwargs: Any) -> InlineConnection:
    """Like ``aiosqlite.connect``: an awaitable connection to the file ``database``."""
    return InlineConnection(lambda: sqlite3.connect(database, **kwargs))
