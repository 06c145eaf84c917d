"""A robot machine running only RelayBot's state table (no mission tasks), on virtual time."""

from __future__ import annotations

import asyncio
from typing import Any

from behaviours.context import RobotContext
from behaviours.machine import RobotMachine
from behaviours.profile import BaseProfile, StateTask
from behaviours.profiles.delivery import states
from hal.backend import Devices
from hal.ports import system_wall_clock
from robotd.config import Settings
from robotd.config.loader import defaults


class DictStore(dict[str, Any]):
    def put(self, key: str, value: Any) -> None:
        self[key] = value

    def delete(self, key: str) -> None:
        self.pop(key, None)

    async def flush(self) -> None:
        return None


class TableProfile(BaseProfile):
    """The delivery tables and nothing else; records every transition with its time."""

    name = "delivery_table"

    def __init__(self, tasks: dict[str, StateTask] | None = None) -> None:
        self.tasks = tasks or {}

    def mission_states(self) -> list[str | dict[str, Any]]:
        return states.mission_states()

    def mission_transitions(self) -> list[dict[str, Any]]:
        return states.mission_transitions()

    def state_tasks(self) -> dict[str, StateTask]:
        return self.tasks


class TableRig:
    def __init__(self, profile: TableProfile) -> None:
        self.moves: list[tuple[float, str, str, str]] = []
        self.motor_stops = 0
        self.ctx = RobotContext(Devices(), Settings(defaults()), DictStore(), system_wall_clock,
                                lambda kind, **f: None)
        self.machine = RobotMachine(profile, self.ctx, on_transition=self._moved,
                                    stop_motors=self._stop)
        self.task: asyncio.Task[None] | None = None
        self._moved_event: asyncio.Event | None = None

    def _moved(self, src: str, dst: str, trigger: str) -> None:
        self.moves.append((asyncio.get_running_loop().time(), src, dst, trigger))
        if self._moved_event is not None:
            self._moved_event.set()

    async def left(self, path: str) -> None:
        """Return once the machine is no longer in ``path``."""
        self._moved_event = asyncio.Event()
        while self.machine.state == path:
            self._moved_event.clear()
            await self._moved_event.wait()

    async def _stop(self) -> None:
        self.motor_stops += 1

    async def start(self) -> None:
        """Boot and start the mission: the machine is in ``mission.waiting``."""
        self.task = asyncio.create_task(self.machine.run(lambda: None))
        await asyncio.sleep(0)
        assert await self.machine.trigger("booted")
        assert await self.machine.trigger("start_mission")

    async def close(self) -> None:
        assert self.task is not None
        self.task.cancel()
        await asyncio.gather(self.task, return_exceptions=True)
