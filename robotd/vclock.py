"""An event loop whose clock the simulator governs.

``VirtualTimeLoop(speed=None)`` jumps its clock to the next timer whenever nothing is ready
(no callbacks, no readable socket), so a 20-minute mission runs in seconds and runs the same
way every time. ``speed=1.0`` runs against the wall clock (``--realtime``), ``speed=X`` X times
faster. Real file descriptors (the control socket, a pseudo-terminal) are polled on every
iteration in every mode, so ``robotctl`` works against a simulation.

Work that happens outside the loop (a thread answering through ``call_soon_threadsafe``) must
hold the clock with ``loop.hold_time()`` while it runs, otherwise virtual time would run ahead
of it; ``run_in_executor`` does this by itself.
"""

from __future__ import annotations

import asyncio
import contextlib
import selectors
import threading
import time
from collections.abc import Callable, Iterator
from concurrent.futures import Executor
from typing import Any, TypeVar

T = TypeVar("T")

# A blocked real select() while time is held wakes up this often to re-check the hold.
_HOLD_POLL_S = 0.05
# With callbacks ready (no time passes), real file descriptors are polled on every Nth turn
# only: a simulation turns the loop ~1000 times per virtual second and a poll is a system call
# plus the selector's Python. Real I/O still never waits for virtual time to move.
_READY_POLL_EVERY = 8


class _ClockSelector(selectors.BaseSelector):
    """Wraps the real selector; advances virtual time instead of sleeping."""

    def __init__(self, loop: VirtualTimeLoop) -> None:
        self._inner = selectors.DefaultSelector()
        self._loop = loop

    def register(self, fileobj: Any, events: int, data: Any = None) -> selectors.SelectorKey:
        return self._inner.register(fileobj, events, data)

    def unregister(self, fileobj: Any) -> selectors.SelectorKey:
        return self._inner.unregister(fileobj)

    def modify(self, fileobj: Any, events: int, data: Any = None) -> selectors.SelectorKey:
        return self._inner.modify(fileobj, events, data)

    def select(
        self, timeout: float | None = None
    ) -> list[tuple[selectors.SelectorKey, int]]:
        return self._loop._select(self._inner, timeout)

    def close(self) -> None:
        self._inner.close()

    def get_map(self) -> Any:
        return self._inner.get_map()


class VirtualTimeLoop(asyncio.SelectorEventLoop):
    """A selector event loop with a virtual (speed=None) or scaled wall clock."""

    def __init__(self, speed: float | None = None, start_s: float = 0.0) -> None:
        if speed is not None and speed <= 0:
            msg = f"speed must be > 0, got {speed}"
            raise ValueError(msg)
        self.speed = speed
        self._virtual_s = start_s
        self._real_origin = time.monotonic()
        self._virtual_origin = start_s
        self._holds = 0
        self._holds_lock = threading.Lock()
        self._unpolled_turns = 0
        super().__init__(selector=_ClockSelector(self))
        self._clock_resolution = 1e-9

    @property
    def virtual(self) -> bool:
        return self.speed is None

    def time(self) -> float:
        if self.speed is None:
            return self._virtual_s
        return self._virtual_origin + (time.monotonic() - self._real_origin) * self.speed

    def set_speed(self, speed: float | None) -> None:
        """Switch between virtual time and a wall-clock speed without a jump in ``time()``."""
        now = self.time()
        self.speed = speed
        self._virtual_s = now
        self._virtual_origin = now
        self._real_origin = time.monotonic()

    @contextlib.contextmanager
    def hold_time(self) -> Iterator[None]:
        """Keep virtual time still while work outside the loop is under way."""
        with self._holds_lock:
            self._holds += 1
        try:
            yield
        finally:
            with self._holds_lock:
                self._holds -= 1
            # Released by another thread: wake a select() that may be waiting on the hold.
            # On the loop's own thread the loop is running this code, not waiting.
            if threading.get_ident() != self._thread_id:  # type: ignore[attr-defined]
                self._write_to_self()  # type: ignore[attr-defined]

    def run_in_executor(  # type: ignore[override]
        self, executor: Executor | None, func: Callable[..., T], *args: Any
    ) -> asyncio.Future[T]:
        if self.speed is not None:
            return super().run_in_executor(executor, func, *args)

        def held() -> T:
            return func(*args)

        with self._holds_lock:
            self._holds += 1
        fut = super().run_in_executor(executor, held)

        def release(_: asyncio.Future[T]) -> None:
            with self._holds_lock:
                self._holds -= 1

        fut.add_done_callback(release)
        return fut

    def _select(
        self, inner: selectors.BaseSelector, timeout: float | None
    ) -> list[tuple[selectors.SelectorKey, int]]:
        if self.speed is not None:
            real_timeout = None if timeout is None else timeout / self.speed
            return inner.select(real_timeout)
        if timeout == 0:
            self._unpolled_turns += 1
            if self._unpolled_turns < _READY_POLL_EVERY:
                return []
        self._unpolled_turns = 0
        events = inner.select(0)
        if events or timeout == 0:
            return events
        if self._holds > 0 or timeout is None:
            # Something outside the loop is working, or no timer at all: wait for real I/O.
            return inner.select(_HOLD_POLL_S if self._holds > 0 else None)
        self._virtual_s += timeout
        return []


class VirtualTimePolicy(asyncio.DefaultEventLoopPolicy):
    """An event loop policy whose new loops are ``VirtualTimeLoop(speed)``."""

    def __init__(self, speed: float | None = None) -> None:
        super().__init__()
        self._speed = speed

    def new_event_loop(self) -> VirtualTimeLoop:
        return VirtualTimeLoop(self._speed)


def run(main: Any, *, speed: float | None = None) -> Any:
    """Run a coroutine on a fresh ``VirtualTimeLoop`` (like ``asyncio.run``)."""
    with asyncio.Runner(loop_factory=lambda: VirtualTimeLoop(speed)) as runner:
        return runner.run(main)
