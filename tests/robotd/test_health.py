"""Loop lag figures and the watchdog that is fed only while the loop is healthy."""

from __future__ import annotations

import asyncio
import socket
from pathlib import Path

from robotd.health import LoopMonitor, WatchdogFeeder, percentile
from robotd.sdnotify import Notifier
from sim import vclock


class TestLoopMonitor:
    def test_figures_are_percentiles_of_the_recorded_lags(self) -> None:
        monitor = LoopMonitor(lambda: 100.0)
        for lag_ms in range(1, 101):
            monitor.record(float(lag_ms))
        figures = monitor.figures()
        assert (figures["p50_ms"], figures["p99_ms"], figures["max_ms"]) == (50.0, 99.0, 100.0)
        assert monitor.healthy

    def test_a_lag_over_the_limit_makes_the_loop_unhealthy(self) -> None:
        monitor = LoopMonitor(lambda: 100.0)
        monitor.record(250.0)
        assert not monitor.healthy

    def test_percentile_is_nearest_rank(self) -> None:
        assert percentile([1.0, 2.0, 3.0, 4.0], 50) == 2.0
        assert percentile([], 99) == 0.0


class TestWatchdogFeeder:
    def test_beats_at_half_the_period_and_skips_while_the_loop_lags(self,
                                                                    tmp_path: Path) -> None:
        path = str(tmp_path / "notify")
        with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as manager:
            manager.bind(path)
            manager.setblocking(False)
            notifier = Notifier({"NOTIFY_SOCKET": path, "WATCHDOG_USEC": "2000000"})
            monitor = LoopMonitor(lambda: 100.0)
            feeder = WatchdogFeeder(notifier, monitor)

            async def main() -> None:
                task = asyncio.create_task(feeder.run(lambda: None))
                await asyncio.sleep(3.5)  # beats at 0, 1, 2, 3 s
                monitor.record(500.0)
                await asyncio.sleep(2.0)  # 4 and 5 s skipped
                task.cancel()

            vclock.run(main())
            beats = []
            while True:
                try:
                    beats.append(manager.recv(64))
                except BlockingIOError:
                    break
        assert beats == [b"WATCHDOG=1"] * 4
        assert feeder.skipped == 2
