"""A daemon on a real event loop with a control socket, and a JSON-RPC test client."""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import json
import shutil
import tempfile
from collections.abc import AsyncIterator, Callable
from pathlib import Path
from typing import Any

from behaviours.profile import BaseProfile
from behaviours.profiles.idle import IdleProfile
from hal.backend import Devices
from hal.ports import system_wall_clock
from hal.readings import LinkStats, MotorCommand
from robotd.config import Settings
from robotd.config.loader import defaults
from robotd.daemon import Daemon


class RecordingMotors:
    """A motor board that records commands and stops (the test's view of the wheels)."""

    name = "motors"

    def __init__(self) -> None:
        self.commands: list[MotorCommand] = []
        self.stops = 0
        self.started = False
        self._listeners: list[Callable[[bool], None]] = []

    @property
    def connected(self) -> bool:
        return self.started

    async def start(self) -> None:
        self.started = True

    async def stop(self) -> None:
        self.stops += 1

    async def close(self) -> None:
        self.started = False

    async def drive(self, command: MotorCommand) -> None:
        self.commands.append(command)

    def on_link_change(self, callback: Callable[[bool], None]) -> None:
        self._listeners.append(callback)

    def link_stats(self) -> LinkStats:
        return LinkStats(connected=self.started, sent=len(self.commands))

    def status(self) -> dict[str, Any]:
        return {"commands": len(self.commands), "stops": self.stops}


class RpcClient:
    def __init__(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        self.reader, self.writer = reader, writer
        self._ids = itertools.count(1)
        self.notifications: list[dict[str, Any]] = []

    @classmethod
    async def connect(cls, path: str) -> RpcClient:
        reader, writer = await asyncio.open_unix_connection(path, limit=1 << 22)
        return cls(reader, writer)

    async def send_line(self, line: bytes) -> None:
        self.writer.write(line + b"\n")
        await self.writer.drain()

    async def read(self) -> dict[str, Any]:
        line = await asyncio.wait_for(self.reader.readline(), 10)
        assert line, "connection closed"
        message: dict[str, Any] = json.loads(line)
        return message

    async def reply(self) -> dict[str, Any]:
        """The next reply, keeping notifications that arrive before it."""
        while True:
            message = await self.read()
            if "method" in message and "id" not in message:
                self.notifications.append(message)
                continue
            return message

    async def call(self, method: str, params: dict[str, Any] | None = None) -> dict[str, Any]:
        request = {"jsonrpc": "2.0", "id": next(self._ids), "method": method}
        if params is not None:
            request["params"] = params
        await self.send_line(json.dumps(request).encode())
        return await self.reply()

    async def close(self) -> None:
        self.writer.close()
        with contextlib.suppress(OSError):
            await self.writer.wait_closed()


@contextlib.asynccontextmanager
async def running_daemon(*, profile: BaseProfile | None = None, devices: Devices | None = None,
                         config: dict[str, dict[str, Any]] | None = None,
                         config_path: Path | None = None,
                         handle_signals: bool = False,
                         state_dir: Path | None = None,
                         freeze_gc: bool = False) -> AsyncIterator[Daemon]:
    """A started daemon (READY) in a fresh temporary state dir; stopped on exit."""
    workdir = Path(tempfile.mkdtemp(prefix="rd-"))  # short: Unix socket paths are <= 107 bytes
    values = defaults()
    for section, keys in (config or {}).items():
        values[section].update(keys)
    daemon = Daemon(Settings(values), devices or Devices(), profile or IdleProfile(),
                    state_dir=state_dir or workdir / "state",
                    socket_path=str(workdir / "control.sock"),
                    wall_clock=system_wall_clock, config_path=config_path, notify=False,
                    handle_signals=handle_signals, freeze_gc=freeze_gc)
    task = asyncio.create_task(daemon.run())
    ready = asyncio.ensure_future(daemon.ready.wait())
    await asyncio.wait({task, ready}, timeout=20, return_when=asyncio.FIRST_COMPLETED)
    assert daemon.ready.is_set(), f"daemon did not start: {daemon.start_problems}"
    try:
        yield daemon
    finally:
        daemon.request_stop()
        await asyncio.wait_for(task, 10)
        shutil.rmtree(workdir, ignore_errors=True)
