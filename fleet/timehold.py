"""Keep a virtual-time loop's clock still while database work is under way.

aiosqlite runs each statement in a thread. On ``sim.vclock.VirtualTimeLoop`` the clock
jumps to the next timer whenever the loop has nothing ready, so without a hold a timeout could
fire while a statement is still in its thread. Every request and every monitor pass holds the
clock when the running loop offers ``hold_time()``; on a normal loop this does nothing.
"""

from __future__ import annotations

import asyncio
import contextlib
from contextlib import AbstractContextManager
from typing import Any

from starlette.types import ASGIApp, Receive, Scope, Send

_NO_HOLD: contextlib.nullcontext[None] = contextlib.nullcontext()


def hold_loop_time() -> AbstractContextManager[None]:
    """The running loop's ``hold_time()``, or a context that does nothing (every request takes
    one: the loop's own context manager is returned, not wrapped in another)."""
    hold: Any = getattr(asyncio.get_running_loop(), "hold_time", None)
    if hold is None:
        return _NO_HOLD
    held: AbstractContextManager[None] = hold()
    return held


class HoldTimeMiddleware:
    """ASGI middleware: each HTTP request runs with the loop's clock held."""

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        with hold_loop_time():
            await self.app(scope, receive, send)
