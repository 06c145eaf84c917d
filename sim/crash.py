"""Killing one robot's daemon inside a simulator run, as SIGKILL would, and starting it again.

The simulator runs every robot's daemon in one process, so a kill is emulated:
``Daemon.crash()`` abandons its state store (nothing more reaches the disk: what was not
committed is lost, as in a killed process) and skips the orderly stop (no STOP for the wheels,
no flush); the motor board's USB port vanishes first, so the board runs on and its deadman stops
the wheels 500 ms after the last command, as after a real kill. What differs from SIGKILL: the
in-process daemon's tasks are cancelled rather than frozen mid-instruction (a ``finally`` of a
device driver still runs, but cannot reach the unplugged board), and a SQLite write already
handed to its thread completes, which a real kill may or may not let happen (both leave the
database consistent). ``restart`` plugs the board back and runs a new ``Daemon`` (new profile,
same settings, devices, state directory and control socket).
"""

from __future__ import annotations

import asyncio
import contextlib
import contextvars
from collections.abc import Callable
from typing import Any

import structlog

log = structlog.get_logger(__name__)

Record = Callable[[dict[str, Any]], None]


class DaemonKeeper:
    """Holds each robot's daemon task; ``kill`` and ``restart`` act on one robot.

    Args:
        robots: name -> ``SimRobot`` (its ``daemon`` is replaced on restart).
        tasks: name -> the task running its daemon (replaced by a placeholder while it is down,
            so the runner does not take a kill for a daemon that stopped early).
        build: name -> a new, not yet started ``Daemon`` for that robot.
        record: writes an event into the run's report.
    """

    def __init__(self, robots: dict[str, Any], tasks: dict[str, asyncio.Task[Any]],
                 build: Callable[[str], Any], record: Record) -> None:
        self.robots = robots
        self.tasks = tasks
        self.build = build
        self.record = record
        self.kills = 0
        self._later: set[asyncio.Task[None]] = set()

    def is_down(self, name: str) -> bool:
        return self.tasks[name].get_name().endswith(".down")

    def context_of(self, name: str) -> contextvars.Context:
        """The context a robot's tasks run in: with several robots every log line they write
        names the robot (``robot=...``), so that a warning says whose it is."""
        context = contextvars.copy_context()
        if len(self.robots) > 1:
            context.run(structlog.contextvars.bind_contextvars, robot=name)
        return context

    async def kill(self, name: str, restart_after_s: float | None = None) -> None:
        robot = self.robots[name]
        if self.is_down(name):
            return
        daemon = robot.daemon
        state = daemon.state
        robot.rig.unplug_mcu()  # the process's port closes with it; the board runs on
        self.context_of(name).run(daemon.crash)  # what it logs as it dies names the robot
        task = self.tasks[name]
        self.tasks[name] = asyncio.create_task(asyncio.Event().wait(), name=f"daemon.{name}.down")
        task.cancel()
        await asyncio.gather(task, return_exceptions=True)
        self.kills += 1
        log.warning("sim.robot_killed", robot=name, state=state)
        if restart_after_s is not None:
            later = asyncio.create_task(self._restart_later(name, restart_after_s))
            self._later.add(later)
            later.add_done_callback(self._later.discard)

    async def _restart_later(self, name: str, delay_s: float) -> None:
        await asyncio.sleep(delay_s)
        await self.restart(name)
        self.record({"kind": "script", "action": "robot.restart", "robot": name})

    async def restart(self, name: str) -> None:
        if not self.is_down(name):
            return
        robot = self.robots[name]
        robot.rig.replug_mcu()
        await asyncio.sleep(0)  # the board's port is back before the new daemon opens it
        daemon = self.build(name)
        robot.daemon = daemon
        down = self.tasks[name]
        self.tasks[name] = asyncio.create_task(daemon.run(), name=f"daemon.{name}",
                                               context=self.context_of(name))
        down.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await down
        log.warning("sim.robot_restarted", robot=name)

    async def replace(self, name: str, changes: dict[str, Any]) -> None:
        """Stops the robot's daemon in order (as ``systemctl stop`` would) and starts a new one
        on the same hardware and state directory with ``changes`` (dotted key -> value) laid
        over its settings: a survey handing over to the profile that drives on its map."""
        from robotd.config.settings import Settings

        robot = self.robots[name]
        old = self.tasks[name]
        # A placeholder first, so the runner does not take the stop for a daemon that died.
        self.tasks[name] = asyncio.create_task(asyncio.Event().wait(), name=f"daemon.{name}.down")
        robot.daemon.request_stop()
        await asyncio.gather(old, return_exceptions=True)
        values = robot.settings.as_dict()
        for dotted, value in changes.items():
            section, _, key = dotted.partition(".")
            checked, error = Settings.option(dotted).check(value)
            if error is not None:
                msg = f"{dotted}: {error}"
                raise ValueError(msg)
            values[section][key] = checked
        robot.settings = Settings(values, source=robot.settings.source)
        await asyncio.sleep(0)
        await self.restart(name)
        log.warning("sim.robot_replaced", robot=name, changes=sorted(changes))

    async def close(self) -> None:
        for task in list(self._later):
            task.cancel()
        await asyncio.gather(*self._later, return_exceptions=True)
