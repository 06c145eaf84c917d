"""Opt-in debug: the event loop's long steps, by the CPU time they took, named by their task.

The loop monitor (``robotd.health``) says *that* the loop was late; this says *which step* held
it. asyncio's own debug mode (``loop.slow_callback_duration``) measures wall time, which on a
shared machine counts the time the process was preempted too. Here each callback the loop runs
(a ``Handle``: a task's step, a reader callback, a timer) is timed by ``time.thread_time()``,
the CPU time of the loop's thread, so only the work the step itself did is counted.

asyncio has no public per-callback hook, so ``install()`` wraps ``asyncio.Handle._run`` for the
whole process (``uninstall()`` restores it). It is debug machinery: off unless the environment
asks for it (``ROBOTD_STEP_CPU_MS=2 robotd run ...``), and then ``status`` carries
``slow_steps``, one entry per step name with its count and CPU figures, and each step over the
threshold is logged once per new maximum (``loop.slow_step``).
"""

from __future__ import annotations

import asyncio
import os
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import structlog

log = structlog.get_logger(__name__)

ENV = "ROBOTD_STEP_CPU_MS"


@dataclass
class StepFigures:
    """The steps of one name over the threshold."""

    count: int = 0
    cpu_ms: float = 0.0
    max_cpu_ms: float = 0.0
    max_wall_ms: float = 0.0


class StepCpu:
    """Records every loop step whose thread CPU time exceeds ``threshold_ms``.

    Args:
        threshold_ms: steps taking more CPU than this are recorded.
    """

    def __init__(self, threshold_ms: float) -> None:
        if not threshold_ms > 0:
            msg = f"{ENV}: the threshold must be a positive number of ms, not {threshold_ms}"
            raise ValueError(msg)
        self.threshold_ms = threshold_ms
        self.steps: dict[str, StepFigures] = {}
        self._original: Callable[[asyncio.Handle], None] | None = None

    @classmethod
    def from_env(cls, environ: Mapping[str, str] = os.environ) -> StepCpu | None:
        """The profiler ``ROBOTD_STEP_CPU_MS`` asks for, or None when it is unset or empty."""
        raw = environ.get(ENV, "").strip()
        if not raw:
            return None
        try:
            threshold_ms = float(raw)
        except ValueError:
            msg = f"{ENV}: {raw!r} is not a number of ms"
            raise ValueError(msg) from None
        return cls(threshold_ms)

    def install(self) -> None:
        """Time every ``Handle`` the process's loops run from now on."""
        if self._original is not None:
            return
        original = asyncio.Handle._run
        self._original = original
        profiler = self

        def timed_run(handle: asyncio.Handle) -> None:
            cpu0, wall0 = time.thread_time(), time.perf_counter()
            try:
                original(handle)
            finally:
                cpu_ms = (time.thread_time() - cpu0) * 1000.0
                if cpu_ms > profiler.threshold_ms:
                    profiler.record(step_name(handle), cpu_ms,
                                    (time.perf_counter() - wall0) * 1000.0)

        asyncio.Handle._run = timed_run  # type: ignore[method-assign,assignment]

    def uninstall(self) -> None:
        if self._original is not None:
            asyncio.Handle._run = self._original  # type: ignore[method-assign,assignment]
            self._original = None

    def record(self, name: str, cpu_ms: float, wall_ms: float) -> None:
        figures = self.steps.setdefault(name, StepFigures())
        figures.count += 1
        figures.cpu_ms += cpu_ms
        figures.max_wall_ms = max(figures.max_wall_ms, wall_ms)
        if cpu_ms > figures.max_cpu_ms:
            figures.max_cpu_ms = cpu_ms
            log.info("loop.slow_step", step=name, cpu_ms=round(cpu_ms, 2),
                     wall_ms=round(wall_ms, 2))

    def figures(self) -> dict[str, Any]:
        """``{"threshold_ms", "steps": {name: {count, cpu_ms, max_cpu_ms, max_wall_ms}}}``,
        the names by total CPU, largest first."""
        ordered = sorted(self.steps.items(), key=lambda item: -item[1].cpu_ms)
        return {"threshold_ms": self.threshold_ms, "steps": {
            name: {"count": f.count, "cpu_ms": round(f.cpu_ms, 2),
                   "max_cpu_ms": round(f.max_cpu_ms, 2), "max_wall_ms": round(f.max_wall_ms, 2)}
            for name, f in ordered}}


def step_name(handle: asyncio.Handle) -> str:
    """A task's step is named by its coroutine (``Ld19Lidar._supervise``) and, after ``>``, the
    innermost coroutine it waits in now; any other callback by its qualified name."""
    callback = handle._callback  # type: ignore[attr-defined]
    owner = getattr(callback, "__self__", None)
    if isinstance(owner, asyncio.Task):
        coro = owner.get_coro()
        outer = getattr(coro, "__qualname__", type(coro).__name__)
        inner = _innermost(coro)
        return outer if inner in (None, outer) else f"{outer} > {inner}"
    func = getattr(callback, "__func__", callback)
    name = getattr(func, "__qualname__", None) or type(callback).__qualname__
    protocol = getattr(owner, "_protocol", None)  # a transport's reader: name whom it feeds
    return name if protocol is None else f"{name} ({type(protocol).__qualname__})"


def _innermost(coro: Any) -> str | None:
    name = None
    for _ in range(64):
        awaited = getattr(coro, "cr_await", None)
        if awaited is None or not hasattr(awaited, "cr_await"):
            return name
        coro = awaited
        name = getattr(coro, "__qualname__", None)
    return name
