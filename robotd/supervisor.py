"""Starts services in dependency order, restarts them with backoff, stops them in reverse."""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

import structlog

from behaviours.service import Service

log = structlog.get_logger(__name__)

EventSink = Callable[..., None]


@dataclass(frozen=True, slots=True)
class RestartPolicy:
    base_s: float = 0.5
    max_s: float = 30.0
    max_failures: int = 5
    stable_s: float = 10.0
    """Up this long, a service's next failure counts as the first of a new streak."""

    def delay_s(self, failures_in_row: int) -> float:
        return float(min(self.max_s, self.base_s * 2 ** max(0, failures_in_row - 1)))


class DeviceService:
    """A device from ``Devices.distinct()`` as a service: started, held open, stopped."""

    def __init__(self, device: Any, *, critical: bool = True,
                 depends_on: tuple[str, ...] = ()) -> None:
        self.device = device
        self.name = f"device.{getattr(device, 'name', type(device).__name__)}"
        self.critical = critical
        self.depends_on = depends_on

    async def run(self, ready: Callable[[], None]) -> None:
        await self.device.start()
        ready()
        try:
            await asyncio.get_running_loop().create_future()
        finally:
            await self.device.close()


@dataclass
class _Slot:
    service: Service
    state: str = "new"
    restarts: int = 0
    failures_in_row: int = 0
    last_error: str | None = None
    up_since_s: float | None = None
    task: asyncio.Task[None] | None = None
    ready: asyncio.Event = field(default_factory=asyncio.Event)
    first_failure: asyncio.Event = field(default_factory=asyncio.Event)


class StartFailed(Exception):
    """Critical services did not come up; ``problems`` holds one line each."""

    def __init__(self, problems: list[str]) -> None:
        self.problems = problems
        super().__init__("; ".join(problems))


class Supervisor:
    """Owns the service tasks.

    Args:
        services: in any order; started after the ones they depend on.
        policy: restart backoff and the estop threshold for critical services.
        emit: ``emit(kind, **fields)`` for service events ("service" up/down/restart).
        on_critical: called with (service name, error) when a critical service keeps failing.
    """

    def __init__(self, services: Iterable[Service], *, policy: RestartPolicy, emit: EventSink,
                 on_critical: Callable[[str, str], None], start_timeout_s: float = 15.0) -> None:
        self._slots: dict[str, _Slot] = {}
        self.add(services)
        self.policy = policy
        self._emit = emit
        self._on_critical = on_critical
        self._start_timeout_s = start_timeout_s
        self._stopping = False

    @property
    def names(self) -> list[str]:
        return list(self._slots)

    def add(self, services: Iterable[Service]) -> None:
        """Add services; the next ``start`` starts them (they may depend on earlier ones)."""
        known = {name: slot.service for name, slot in self._slots.items()}
        for service in _in_dependency_order(list(services), known):
            self._slots[service.name] = _Slot(service)

    async def start(self) -> None:
        """Start each new service and wait until it is ready; StartFailed for critical ones."""
        problems: list[str] = []
        failed = {n for n, s in self._slots.items() if s.task is not None and not s.ready.is_set()}
        for slot in self._slots.values():
            if slot.task is not None:
                continue
            missing = [d for d in slot.service.depends_on if d in failed]
            if missing:
                failed.add(slot.service.name)
                slot.state = "not started"
                if slot.service.critical:
                    problems.append(f"{slot.service.name}: not started, needs {', '.join(missing)}")
                continue
            slot.task = asyncio.create_task(self._keep_running(slot), name=slot.service.name)
            waiters = [asyncio.ensure_future(slot.ready.wait()),
                       asyncio.ensure_future(slot.first_failure.wait())]
            _, pending = await asyncio.wait(waiters, timeout=self._start_timeout_s,
                                            return_when=asyncio.FIRST_COMPLETED)
            for waiter in pending:
                waiter.cancel()
            if slot.ready.is_set():
                continue
            why = slot.last_error or f"not ready within {self._start_timeout_s:g} s"
            if slot.service.critical:
                failed.add(slot.service.name)
                problems.append(f"{slot.service.name}: {why}")
                continue
            log.warning("service.start_failed", service=slot.service.name, error=why)
        if problems:
            raise StartFailed(problems)

    async def _keep_running(self, slot: _Slot) -> None:
        loop = asyncio.get_running_loop()
        name = slot.service.name

        def ready() -> None:
            if slot.state != "up":
                slot.state = "up"
                slot.up_since_s = loop.time()
                slot.ready.set()
                log.info("service.up", service=name, restarts=slot.restarts)
                self._emit("service", service=name, status="up", restarts=slot.restarts)

        while True:
            slot.state = "starting"
            try:
                await slot.service.run(ready)
                error = "returned"
            except asyncio.CancelledError:
                slot.state = "stopped"
                raise
            except Exception as exc:  # a service failure of any kind is handled by the policy
                error = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
            was_up_s = loop.time() - slot.up_since_s if slot.up_since_s is not None else 0.0
            stable = slot.state == "up" and was_up_s >= self.policy.stable_s
            slot.failures_in_row = 1 if stable else slot.failures_in_row + 1
            slot.last_error, slot.state, slot.up_since_s = error, "backoff", None
            slot.first_failure.set()
            delay_s = self.policy.delay_s(slot.failures_in_row)
            log.warning("service.down", service=name, error=error,
                        failures_in_row=slot.failures_in_row, restart_in_s=delay_s)
            self._emit("service", service=name, status="down", error=error,
                       failures_in_row=slot.failures_in_row)
            if slot.service.critical and slot.failures_in_row == self.policy.max_failures:
                log.error("service.gave_up", service=name, failures=slot.failures_in_row)
                self._on_critical(name, error)
            await asyncio.sleep(delay_s)
            slot.restarts += 1
            self._emit("service", service=name, status="restart", restarts=slot.restarts)

    async def stop(self, timeout_s: float) -> list[str]:
        """Stop services in reverse start order, each within ``timeout_s``; return problems."""
        self._stopping = True
        problems: list[str] = []
        for slot in reversed(self._slots.values()):
            task = slot.task
            if task is None or task.done():
                continue
            slot.state = "stopping"
            task.cancel()
            done, _ = await asyncio.wait({task}, timeout=timeout_s)
            if not done:
                problems.append(f"{slot.service.name}: did not stop within {timeout_s:g} s")
                log.error("service.stop_timeout", service=slot.service.name, timeout_s=timeout_s)
                continue
            with contextlib.suppress(asyncio.CancelledError):
                error = task.exception()
                if error is not None:
                    problems.append(f"{slot.service.name}: {error}")
            slot.state = "stopped"
            self._emit("service", service=slot.service.name, status="stopped")
        return problems

    def status(self) -> list[dict[str, Any]]:
        out = []
        for name, s in self._slots.items():
            entry: dict[str, Any] = {
                "name": name, "state": s.state, "critical": s.service.critical,
                "restarts": s.restarts, "failures_in_row": s.failures_in_row,
                "last_error": s.last_error}
            figures = getattr(s.service, "status", None)
            if callable(figures):  # a service's own figures (the localisation's pose, ...)
                try:
                    entry["figures"] = figures()
                except Exception as exc:  # one service's broken status must not hide the rest
                    entry["figures"] = {"error": repr(exc)}
            out.append(entry)
        return out


def _in_dependency_order(services: list[Service],
                         known: dict[str, Service] | None = None) -> list[Service]:
    """Topological order, keeping the given order among independent services."""
    known = known or {}
    by_name: dict[str, Service] = {}
    for service in services:
        if service.name in by_name or service.name in known:
            msg = f"two services are named {service.name!r}"
            raise ValueError(msg)
        by_name[service.name] = service
    ordered: list[Service] = []
    marks: dict[str, str] = {}

    def visit(service: Service, path: tuple[str, ...]) -> None:
        if marks.get(service.name) == "done":
            return
        if marks.get(service.name) == "visiting":
            msg = f"services depend on each other: {' -> '.join((*path, service.name))}"
            raise ValueError(msg)
        marks[service.name] = "visiting"
        for dep in service.depends_on:
            if dep in known:
                continue
            if dep not in by_name:
                msg = f"service {service.name!r} depends on unknown service {dep!r}"
                raise ValueError(msg)
            visit(by_name[dep], (*path, service.name))
        marks[service.name] = "done"
        ordered.append(service)

    for service in services:
        visit(service, ())
    return ordered
