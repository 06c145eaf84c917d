"""Event-loop lag, measured all the time, and the systemd watchdog fed only while it is low."""

from __future__ import annotations

import asyncio
import math
from collections import deque
from collections.abc import Callable
from typing import Any

import structlog

from hal.looptime.timer_chain import timer_chain
from robotd.sdnotify import Notifier

log = structlog.get_logger(__name__)

SAMPLE_PERIOD_S = 0.25
WINDOW_SAMPLES = 240
"""One minute of samples for the percentiles in ``status``."""


class LoopMonitor:
    """Wakes every period and records how late it woke up (the loop's lag).

    Each wake-up is a timer callback (``hal.looptime.timer_chain``), not a task waking from a sleep:
    one loop turn instead of two, four times a second, also in the simulator.
    """

    name = "loop-monitor"
    critical = False
    depends_on: tuple[str, ...] = ()

    def __init__(self, lag_warn_ms: Callable[[], float], period_s: float = SAMPLE_PERIOD_S) -> None:
        self._lag_warn_ms = lag_warn_ms
        self.period_s = period_s
        self._lags_ms: deque[float] = deque(maxlen=WINDOW_SAMPLES)
        self._last_ms = 0.0
        self._warned = False

    async def run(self, ready: Callable[[], None]) -> None:
        loop = asyncio.get_running_loop()
        ready()
        period_s = self.period_s
        expected = loop.time() + period_s

        def sample() -> float:
            nonlocal expected
            now = loop.time()
            self.record(max(0.0, (now - expected) * 1000.0))
            expected = now + period_s
            return period_s

        await timer_chain(sample, period_s)

    def record(self, lag_ms: float) -> None:
        self._last_ms = lag_ms
        self._lags_ms.append(lag_ms)
        unhealthy = lag_ms > self._lag_warn_ms()
        if unhealthy and not self._warned:
            log.warning("loop.lagging", lag_ms=round(lag_ms, 1), limit_ms=self._lag_warn_ms())
        elif self._warned and not unhealthy:
            log.info("loop.recovered", lag_ms=round(lag_ms, 1))
        self._warned = unhealthy

    @property
    def healthy(self) -> bool:
        return self._last_ms <= self._lag_warn_ms()

    def figures(self) -> dict[str, Any]:
        lags = sorted(self._lags_ms)
        if not lags:
            return {"last_ms": 0.0, "p50_ms": 0.0, "p99_ms": 0.0, "max_ms": 0.0, "samples": 0}
        return {
            "last_ms": round(self._last_ms, 3),
            "p50_ms": round(percentile(lags, 50), 3),
            "p99_ms": round(percentile(lags, 99), 3),
            "max_ms": round(lags[-1], 3),
            "samples": len(lags),
        }


class WatchdogFeeder:
    """Sends ``WATCHDOG=1`` at half the systemd period, skipping beats while the loop lags."""

    name = "watchdog"
    critical = False
    depends_on: tuple[str, ...] = (LoopMonitor.name,)

    def __init__(self, notifier: Notifier, monitor: LoopMonitor) -> None:
        self._notifier = notifier
        self._monitor = monitor
        self.skipped = 0

    async def run(self, ready: Callable[[], None]) -> None:
        ready()
        period_s = self._notifier.watchdog_s
        if period_s is None:
            await asyncio.get_running_loop().create_future()  # no watchdog asked for
            return
        while True:
            if self._monitor.healthy:
                self._notifier.notify("WATCHDOG=1")
            else:
                self.skipped += 1
                log.warning("watchdog.skipped", lag=self._monitor.figures()["last_ms"])
            await asyncio.sleep(period_s / 2)


def percentile(ordered: list[float], pct: float) -> float:
    """Nearest-rank percentile of an ascending list."""
    if not ordered:
        return 0.0
    rank = max(0, min(len(ordered) - 1, math.ceil(pct / 100 * len(ordered)) - 1))
    return ordered[rank]
