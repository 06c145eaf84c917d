"""An event loop whose clock the simulator governs.

``VirtualTimeLoop(speed=None)`` jumps its clock to the next timer whenever nothing is ready
(no callbacks, no readable socket), so a 20-minute mission runs in seconds and runs the same
way every time. ``speed=1.0`` runs against the wall clock (``--realtime``), ``speed=X`` X times
faster. Real file descriptors (the control socket, a pseudo-terminal) are polled before every
jump of the clock and every few turns in between, so ``robotctl`` works against a simulation.

Work that happens outside the loop (a thread answering through ``call_soon_threadsafe``) must
hold the clock with ``loop.hold_time()`` while it runs, otherwise virtual time would run ahead
of it; ``run_in_executor`` does this by itself.
"""

from __future__ import annotations

import asyncio
import collections
import contextlib
import contextvars
import itertools
import selectors
import threading
import time
from asyncio import events, format_helpers
from collections.abc import Callable, Iterator
from concurrent.futures import Executor
from heapq import heapify, heappop, heappush
from typing import Any, TypeVar, TypeVarTuple

T = TypeVar("T")
Ts = TypeVarTuple("Ts")

# A blocked real select() while time is held wakes up this often to re-check the hold.
_HOLD_POLL_S = 0.05
# Real file descriptors are polled on every Nth loop turn, and before every jump of the clock
# of at least _POLL_BEFORE_JUMP_S: a simulation turns the loop a few hundred times per virtual
# second, mostly for short jumps, and a poll is a system call (every 8th turn: 2 % of laundry).
# Real I/O waits at most 32 turns (under a millisecond), never past a timeout it could beat.
_READY_POLL_EVERY = 32
_POLL_BEFORE_JUMP_S = 0.02
# asyncio's policy for purging cancelled timers from the queue.
_PURGE_MIN_TIMERS = 100
_PURGE_CANCELLED_FRACTION = 0.5
_MAX_SELECT_TIMEOUT_S = 24 * 3600.0


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
        return self._loop._select_scaled(self._inner, timeout)

    def close(self) -> None:
        self._inner.close()

    def get_map(self) -> Any:
        return self._inner.get_map()


class VirtualTimeLoop(asyncio.SelectorEventLoop):
    """A selector event loop with a virtual (speed=None) or scaled wall clock."""

    # asyncio's loop internals that this loop's turn works on (not in typeshed).
    _ready: collections.deque[Any]
    _scheduled: list[tuple[float, int, Any]]
    _stopping: bool
    _closed: bool
    _debug: bool
    _timer_cancelled_count: int
    _current_handle: Any
    _selector: selectors.BaseSelector
    _process_events: Callable[[list[tuple[selectors.SelectorKey, int]]], None]
    _check_thread: Callable[[], None]
    _check_callback: Callable[[object, str], None]
    # False: every callback runs through Handle._run (bench/bench_sim.py --turns counts there).
    inline_callbacks = True

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
        self._timer_order = itertools.count()
        selector = _ClockSelector(self)
        self._inner_selector = selector._inner
        # One system call says whether any real descriptor is ready (epoll and poll objects);
        # only then does the selector's Python run.
        raw = getattr(self._inner_selector, "_selector", None)
        self._probe: Callable[[float], list[Any]] | None = getattr(raw, "poll", None)
        super().__init__(selector=selector)
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

    # -- callbacks and timers ----------------------------------------------------------------
    # The simulator schedules a few hundred callbacks per virtual second, so these are lean
    # versions of asyncio's (same handles, same semantics): handles are filled in place
    # instead of through three constructors, and timers queue as (when, order, handle) so
    # the heap compares floats in C instead of calling TimerHandle.__lt__ in Python. Timers
    # due at the same moment run in the order they were set. Debug mode uses asyncio's own.

    def call_soon(self, callback: Callable[[*Ts], object], *args: *Ts,
                  context: contextvars.Context | None = None) -> asyncio.Handle:
        if self._debug:
            return super().call_soon(callback, *args, context=context)
        if self._closed:
            msg = "Event loop is closed"
            raise RuntimeError(msg)
        handle: Any = _new_handle(events.Handle)
        handle._context = context if context is not None else contextvars.copy_context()
        handle._loop = self
        handle._callback = callback
        handle._args = args
        handle._cancelled = False
        handle._repr = None
        handle._source_traceback = None
        self._ready.append(handle)
        return handle  # type: ignore[no-any-return]

    def call_later(self, delay: float, callback: Callable[[*Ts], object], *args: *Ts,
                   context: contextvars.Context | None = None) -> asyncio.TimerHandle:
        if self._debug or delay is None:
            return super().call_later(delay, callback, *args, context=context)
        now = self._virtual_s if self.speed is None else self.time()
        return self.call_at(now + delay, callback, *args, context=context)

    def call_at(self, when: float, callback: Callable[[*Ts], object], *args: *Ts,
                context: contextvars.Context | None = None) -> asyncio.TimerHandle:
        if when is None:
            msg = "when cannot be None"
            raise TypeError(msg)
        if self._closed:
            msg = "Event loop is closed"
            raise RuntimeError(msg)
        timer: Any
        if self._debug:
            self._check_thread()
            self._check_callback(callback, "call_at")
            timer = events.TimerHandle(when, callback, args, self, context)
        else:
            timer = _new_handle(_Timer)
            timer._context = context if context is not None else contextvars.copy_context()
            timer._loop = self
            timer._callback = callback
            timer._args = args
            timer._cancelled = False
            timer._repr = None
            timer._source_traceback = None
            timer._when = when
        heappush(self._scheduled, (when, next(self._timer_order), timer))
        timer._scheduled = True
        return timer  # type: ignore[no-any-return]

    def _run_once(self) -> None:
        """One turn: purge cancelled timers, poll or move the clock, run what is due."""
        scheduled = self._scheduled
        count = len(scheduled)
        if count > _PURGE_MIN_TIMERS and (
                self._timer_cancelled_count / count > _PURGE_CANCELLED_FRACTION):
            live = []
            for entry in scheduled:
                if entry[2]._cancelled:
                    entry[2]._scheduled = False
                else:
                    live.append(entry)
            heapify(live)
            self._scheduled = scheduled = live
            self._timer_cancelled_count = 0
        else:
            while scheduled and scheduled[0][2]._cancelled:
                self._timer_cancelled_count -= 1
                heappop(scheduled)[2]._scheduled = False

        ready = self._ready
        busy = bool(ready) or self._stopping
        if self.speed is None:
            self._unpolled_turns += 1
            if (not busy and scheduled and self._holds <= 0
                    and self._unpolled_turns < _READY_POLL_EVERY
                    and (jump_s := scheduled[0][0] - self._virtual_s) < _POLL_BEFORE_JUMP_S):
                if jump_s > 0.0:  # the usual turn: a short jump to the next timer, no poll due
                    self._virtual_s += jump_s
            else:
                self._wait_virtual(busy, scheduled)
            end_s = self._virtual_s + self._clock_resolution
        else:
            timeout = None
            if busy:
                timeout = 0.0
            elif scheduled:
                timeout = min(max(0.0, scheduled[0][0] - self.time()), _MAX_SELECT_TIMEOUT_S)
            self._process_events(self._selector.select(timeout))
            end_s = self.time() + self._clock_resolution
        while scheduled and scheduled[0][0] < end_s:
            timer = heappop(scheduled)[2]
            timer._scheduled = False
            ready.append(timer)

        handle: Any = None
        inline = self.inline_callbacks and not self._debug
        while True:
            if not inline:
                self._run_handles(ready)
            else:
                # Handle._run, inlined: one Python frame less per callback.
                popleft = ready.popleft
                for _ in range(len(ready)):
                    handle = popleft()
                    if handle._cancelled:
                        continue
                    try:
                        handle._context.run(handle._callback, *handle._args)
                    except (SystemExit, KeyboardInterrupt):
                        raise
                    except BaseException as exc:
                        self._callback_failed(handle, exc)
                handle = None  # breaks a cycle when a callback raised
            # Virtual time: the next turn, when it is the usual one, is done here (same order,
            # same polls): callbacks ready and no timer due, or a short jump, no poll due.
            if self._stopping or self.speed is not None:
                return
            if ready:
                if scheduled and scheduled[0][0] < end_s:
                    return
                self._unpolled_turns += 1
                if self._unpolled_turns >= _READY_POLL_EVERY:
                    self._poll_real(0.0)
                continue
            while scheduled and scheduled[0][2]._cancelled:
                self._timer_cancelled_count -= 1
                heappop(scheduled)[2]._scheduled = False
            if (not inline or not scheduled or self._holds > 0  # bench_sim --turns counts turns
                    or self._unpolled_turns + 1 >= _READY_POLL_EVERY
                    or (jump_s := scheduled[0][0] - self._virtual_s) >= _POLL_BEFORE_JUMP_S):
                return
            self._unpolled_turns += 1
            if jump_s > 0.0:
                self._virtual_s += jump_s
            end_s = self._virtual_s + self._clock_resolution
            while scheduled and scheduled[0][0] < end_s:
                timer = heappop(scheduled)[2]
                timer._scheduled = False
                ready.append(timer)

    def _run_handles(self, ready: collections.deque[Any]) -> None:
        """The callbacks ready now, through Handle._run (debug mode; bench_sim --turns)."""
        for _ in range(len(ready)):
            handle = ready.popleft()
            if not handle._cancelled:
                self._current_handle = handle
                try:
                    handle._run()
                finally:
                    self._current_handle = None

    def _callback_failed(self, handle: Any, exc: BaseException) -> None:
        source = format_helpers._format_callback_source(handle._callback, handle._args)
        context: dict[str, Any] = {"message": f"Exception in callback {source}",
                                   "exception": exc, "handle": handle}
        if handle._source_traceback:
            context["source_traceback"] = handle._source_traceback
        self.call_exception_handler(context)

    def _wait_virtual(self, busy: bool, scheduled: list[Any]) -> None:
        """Poll real I/O; move virtual time to the next timer when nothing else is to do."""
        if busy:
            if self._unpolled_turns >= _READY_POLL_EVERY:
                self._poll_real(0.0)
            return
        if scheduled and self._holds <= 0:
            jump_s = min(max(0.0, scheduled[0][0] - self._virtual_s), _MAX_SELECT_TIMEOUT_S)
            if (jump_s >= _POLL_BEFORE_JUMP_S or self._unpolled_turns >= _READY_POLL_EVERY) \
                    and self._poll_real(0.0):
                return  # real I/O first: time moves once it is served
            self._virtual_s += jump_s
            return
        if self._poll_real(0.0):
            return
        # Something outside the loop is working, or no timer at all: wait for real I/O.
        self._poll_real(_HOLD_POLL_S if self._holds > 0 else None)

    def _poll_real(self, timeout_s: float | None) -> bool:
        self._unpolled_turns = 0
        if timeout_s == 0.0 and self._probe is not None and not self._probe(0):
            return False
        events = self._inner_selector.select(timeout_s)
        if events:
            self._process_events(events)
        return bool(events)

    def _select_scaled(
        self, inner: selectors.BaseSelector, timeout: float | None
    ) -> list[tuple[selectors.SelectorKey, int]]:
        speed = self.speed or 1.0
        return inner.select(None if timeout is None else timeout / speed)


_new_handle: Callable[[type[events.Handle]], Any] = object.__new__


class _Timer(events.TimerHandle):
    """A TimerHandle whose cancel() is one call (asyncio.sleep cancels every timer it set)."""

    __slots__ = ()

    def cancel(self) -> None:
        if not self._cancelled:
            if self._scheduled:  # type: ignore[attr-defined]
                self._loop._timer_cancelled_count += 1  # type: ignore[attr-defined]
            self._cancelled = True
            self._callback = None
            self._args = None  # type: ignore[assignment]


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
