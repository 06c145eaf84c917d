"""The supervisor: dependency order, readiness, restart backoff, estop, bounded stop."""

from __future__ import annotations

import asyncio
import itertools
from collections.abc import Callable
from typing import Any

import pytest

from robotd.supervisor import RestartPolicy, StartFailed, Supervisor
from sim import vclock


class Recorder:
    def __init__(self) -> None:
        self.log: list[tuple[float, str, str]] = []
        self.events: list[dict[str, Any]] = []
        self.critical: list[str] = []

    def note(self, name: str, what: str) -> None:
        self.log.append((asyncio.get_running_loop().time(), name, what))

    def emit(self, kind: str, **fields: Any) -> None:
        self.events.append({"kind": kind, **fields})


class FakeService:
    """Becomes ready after ``start_s``; fails ``fail_times`` times first; records everything."""

    def __init__(self, rec: Recorder, name: str, *, depends_on: tuple[str, ...] = (),
                 critical: bool = False, start_s: float = 0.1, fail_times: int = 0,
                 stop_s: float = 0.0, crash_after_s: float | None = None) -> None:
        self.rec, self.name, self.depends_on, self.critical = rec, name, depends_on, critical
        self.start_s, self.fail_times, self.stop_s = start_s, fail_times, stop_s
        self.crash_after_s = crash_after_s

    async def run(self, ready: Callable[[], None]) -> None:
        self.rec.note(self.name, "start")
        await asyncio.sleep(self.start_s)
        if self.fail_times:
            self.fail_times -= 1
            msg = "no device"
            raise OSError(msg)
        ready()
        try:
            if self.crash_after_s is not None:
                await asyncio.sleep(self.crash_after_s)
                msg = "crashed"
                raise RuntimeError(msg)
            await asyncio.sleep(3600)
        finally:
            self.rec.note(self.name, "stopping")
            await asyncio.shield(asyncio.sleep(self.stop_s))
            self.rec.note(self.name, "stopped")


def supervise(rec: Recorder, services: list[Any], **policy: Any) -> Supervisor:
    return Supervisor(services, policy=RestartPolicy(**policy), emit=rec.emit,
                      on_critical=lambda name, error: rec.critical.append(f"{name}: {error}"))


class TestStart:
    def test_services_start_after_their_dependencies_each_once_ready(self) -> None:
        """'b' depends on 'a': a starts and is ready before b starts."""
        rec = Recorder()

        async def main() -> None:
            sup = supervise(rec, [FakeService(rec, "b", depends_on=("a",)),
                                  FakeService(rec, "a", start_s=1.0)])
            await sup.start()
            await sup.stop(1.0)

        vclock.run(main())
        starts = [(t, n) for t, n, w in rec.log if w == "start"]
        assert [n for _, n in starts] == ["a", "b"]
        assert starts[1][0] >= starts[0][0] + 1.0

    def test_a_cycle_or_unknown_dependency_is_refused(self) -> None:
        rec = Recorder()
        with pytest.raises(ValueError, match="depend on each other"):
            supervise(rec, [FakeService(rec, "a", depends_on=("b",)),
                            FakeService(rec, "b", depends_on=("a",))])
        with pytest.raises(ValueError, match="unknown service 'x'"):
            supervise(rec, [FakeService(rec, "a", depends_on=("x",))])

    def test_a_critical_service_that_cannot_start_fails_the_start_with_its_reason(self) -> None:
        rec = Recorder()

        async def main() -> list[str]:
            sup = supervise(rec, [FakeService(rec, "motors", critical=True, fail_times=99),
                                  FakeService(rec, "camera", critical=True, fail_times=99),
                                  FakeService(rec, "drive", depends_on=("motors",),
                                              critical=True)])
            try:
                await sup.start()
            except StartFailed as exc:
                return exc.problems
            finally:
                await sup.stop(1.0)
            return []

        assert vclock.run(main()) == ["motors: OSError: no device", "camera: OSError: no device",
                                      "drive: not started, needs motors"]


class TestRestart:
    def test_a_failing_service_restarts_with_exponential_backoff_up_to_the_cap(self) -> None:
        """Delays 0.5, 1, 2, 2 s (cap 2 s) between attempts."""
        rec = Recorder()

        async def main() -> None:
            sup = supervise(rec, [FakeService(rec, "cam", fail_times=4, start_s=0.0)],
                            base_s=0.5, max_s=2.0, max_failures=100)
            await sup.start()
            await asyncio.sleep(10)
            await sup.stop(1.0)

        vclock.run(main())
        starts = [t for t, _, w in rec.log if w == "start"]
        gaps = [round(b - a, 3) for a, b in itertools.pairwise(starts)]
        assert gaps == [0.5, 1.0, 2.0, 2.0]

    def test_a_critical_service_that_keeps_failing_calls_for_estop_once(self) -> None:
        """Up but crashing again and again: after max_failures in a row, on_critical once."""
        rec = Recorder()

        async def main() -> None:
            service = FakeService(rec, "motors", critical=True, start_s=0.0, crash_after_s=0.5)
            sup = supervise(rec, [service], base_s=0.1, max_s=0.1, max_failures=3)
            await sup.start()
            await asyncio.sleep(10)
            await sup.stop(1.0)

        vclock.run(main())
        assert rec.critical == ["motors: RuntimeError: crashed"]
        downs = [e for e in rec.events if e.get("status") == "down"]
        assert len(downs) > 3

    def test_status_counts_restarts_and_keeps_the_last_error(self) -> None:
        rec = Recorder()

        async def main() -> list[dict[str, Any]]:
            sup = supervise(rec, [FakeService(rec, "cam", fail_times=2, start_s=0.0)],
                            base_s=0.1, max_s=1.0)
            await sup.start()
            await asyncio.sleep(1)
            status = sup.status()
            await sup.stop(1.0)
            return status

        (status,) = vclock.run(main())
        assert status["state"] == "up"
        assert status["restarts"] == 2
        assert status["last_error"] == "OSError: no device"


class TestStop:
    def test_services_stop_in_reverse_order_each_within_its_timeout(self) -> None:
        """A service slower to stop than the timeout is reported and the rest still stop."""
        rec = Recorder()

        async def main() -> list[str]:
            sup = supervise(rec, [FakeService(rec, "a"), FakeService(rec, "b", stop_s=10.0),
                                  FakeService(rec, "c")])
            await sup.start()
            return await sup.stop(1.0)

        problems = vclock.run(main())
        stopping = [n for _, n, w in rec.log if w == "stopping"]
        assert stopping == ["c", "b", "a"]
        assert problems == ["b: did not stop within 1 s"]
