"""What the supervisor runs: the ``Service`` protocol, and a service made of one coroutine."""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from typing import Protocol, runtime_checkable


@runtime_checkable
class Service(Protocol):
    """A long-running task: calls ``ready()`` once it is up; returning or raising is a failure."""

    name: str
    critical: bool
    depends_on: tuple[str, ...]

    async def run(self, ready: Callable[[], None]) -> None: ...


class TaskService:
    """A service that is ready at once and runs one coroutine function for as long as the
    robot runs (the supervisor restarts it by its policy if it returns or raises).

    Args:
        name: the service's name in ``robotctl status`` and the logs.
        run: called with no arguments each time the service starts.
        critical: its failures count towards the e-stop (``supervisor.max_failures``).
        depends_on: names of services that must be ready first.
    """

    def __init__(self, name: str, run: Callable[[], Awaitable[object]], *,
                 critical: bool = False, depends_on: tuple[str, ...] = ()) -> None:
        self.name = name
        self.critical = critical
        self.depends_on = depends_on
        self._run = run

    async def run(self, ready: Callable[[], None]) -> None:
        ready()
        await self._run()
