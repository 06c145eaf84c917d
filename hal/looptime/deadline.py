"""Sleeping until an absolute deadline on the loop's clock, precisely where the OS allows.

asyncio wakes its timers through ``epoll_wait``, whose timeout is whole milliseconds rounded
up, so a plain ``asyncio.sleep`` ends 0-1 ms late: a periodic loop built on it jitters by up to
a millisecond before anything else runs. On Linux, when the loop's clock is the monotonic
clock (a real asyncio loop, not the simulator's virtual one), ``DeadlineSleeper`` arms a
``timerfd`` at the deadline instead and waits for it to become readable, which wakes within
tens of microseconds. Everywhere else it is ``asyncio.sleep``.
"""

from __future__ import annotations

import asyncio
import contextlib
import ctypes
import ctypes.util
import os
import sys
from typing import Any

import structlog

log = structlog.get_logger(__name__)

_CLOCK_MONOTONIC = 1
_TFD_NONBLOCK = 0o4000
_TFD_CLOEXEC = 0o2000000
_TFD_TIMER_ABSTIME = 1


class _Timespec(ctypes.Structure):
    _fields_ = (("tv_sec", ctypes.c_long), ("tv_nsec", ctypes.c_long))


class _Itimerspec(ctypes.Structure):
    _fields_ = (("it_interval", _Timespec), ("it_value", _Timespec))


def _libc() -> Any:
    name = ctypes.util.find_library("c")
    return ctypes.CDLL(name, use_errno=True) if name else None


class _TimerFd:
    """A one-shot CLOCK_MONOTONIC timerfd armed at absolute times."""

    def __init__(self, libc: Any) -> None:
        self._libc = libc
        fd = libc.timerfd_create(_CLOCK_MONOTONIC, _TFD_NONBLOCK | _TFD_CLOEXEC)
        if fd < 0:
            err = ctypes.get_errno()
            raise OSError(err, f"timerfd_create: {os.strerror(err)}")
        self.fd: int = fd

    def arm(self, deadline_s: float) -> None:
        # Deadlines are in the future of a monotonic clock, so never the 0 that would disarm.
        sec = int(deadline_s)
        nsec = int((deadline_s - sec) * 1e9)
        spec = _Itimerspec(_Timespec(0, 0), _Timespec(sec, nsec))
        if self._libc.timerfd_settime(self.fd, _TFD_TIMER_ABSTIME, ctypes.byref(spec), None):
            err = ctypes.get_errno()
            raise OSError(err, f"timerfd_settime: {os.strerror(err)}")

    def drain(self) -> None:
        with contextlib.suppress(BlockingIOError):
            os.read(self.fd, 8)

    def close(self) -> None:
        os.close(self.fd)


def _precise_possible(loop: asyncio.AbstractEventLoop) -> bool:
    # Only a loop whose time() is asyncio's own (time.monotonic, CLOCK_MONOTONIC) and that
    # watches file descriptors; the simulator's virtual clock overrides time().
    return (sys.platform == "linux" and isinstance(loop, asyncio.BaseEventLoop)
            and type(loop).time is asyncio.BaseEventLoop.time
            and hasattr(loop, "add_reader"))


class DeadlineSleeper:
    """``await sleeper.sleep_until(deadline_s)`` for one periodic task; ``close()`` when done.

    ``precise`` says whether the timerfd is in use (False: asyncio.sleep, e.g. in the
    simulator or off Linux).
    """

    def __init__(self, loop: asyncio.AbstractEventLoop | None = None) -> None:
        self._loop = loop or asyncio.get_running_loop()
        self._timer: _TimerFd | None = None
        if _precise_possible(self._loop):
            try:
                libc = _libc()
                if libc is not None:
                    self._timer = _TimerFd(libc)
            except (OSError, AttributeError) as exc:
                log.info("deadline.timerfd_unavailable", error=str(exc))

    @property
    def precise(self) -> bool:
        return self._timer is not None

    async def sleep_until(self, deadline_s: float) -> None:
        """Return at ``deadline_s`` on the loop's clock (at once when it has passed)."""
        loop = self._loop
        timer = self._timer
        if timer is None or deadline_s <= loop.time():
            await asyncio.sleep(max(0.0, deadline_s - loop.time()))
            return
        woken: asyncio.Future[None] = loop.create_future()

        def fired() -> None:
            timer.drain()
            if not woken.done():
                woken.set_result(None)

        timer.arm(deadline_s)
        loop.add_reader(timer.fd, fired)
        try:
            await woken
        finally:
            loop.remove_reader(timer.fd)
            timer.drain()

    def close(self) -> None:
        if self._timer is not None:
            self._timer.close()
            self._timer = None
