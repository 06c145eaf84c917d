"""A run's live view: one Foxglove context, its WebSocket server and recorder, each robot's feed.

A ``VizSession`` is made per process run (``robotd run``: one robot; ``robotd sim``: every
robot of the scenario), never from the SDK's global context, so several sessions (tests in
parallel) do not share channels. The SDK's WebSocket server runs in its own native thread: the
library forces it (its Rust runtime serves clients and drains queues off the event loop);
everything robotd does with it stays on the loop. A session publishes, per robot: the state
machine's state (on each transition, and every second for viewers that join late), every
event, and the structured log (a logging handler on the structlog pipeline).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import foxglove
import structlog
from foxglove.channels import LogChannel
from foxglove.mcap import MCAPWriter
from foxglove.messages import Log, LogLevel

from robotd.viz import messages as fm
from robotd.viz.recorder import RotatingRecorder, open_recording
from robotd.viz.telemetry import FoxgloveTelemetry, json_bytes

log = structlog.get_logger(__name__)

_TICK_S = 1.0
_LEVELS = {logging.DEBUG: LogLevel.Debug, logging.INFO: LogLevel.Info,
           logging.WARNING: LogLevel.Warning, logging.ERROR: LogLevel.Error,
           logging.CRITICAL: LogLevel.Fatal}


class VizError(Exception):
    """The live view could not start (the port is taken, the host is not ours...)."""


class VizSession:
    """The context, its sinks, and the robots' feeds.

    Args:
        name: the server's name, shown by Foxglove.
        many: several robots share the session (topics under ``/<robot>/``).
        periods: the robots' feeds' shortest intervals by kind (``FoxgloveTelemetry``).
    """

    def __init__(self, name: str = "robotd", *, many: bool = False,
                 periods: Mapping[str, float] | None = None) -> None:
        self.name = name
        self.many = many
        self.periods = periods
        self.context = foxglove.Context()
        self.server: Any = None
        self._writer: MCAPWriter | None = None
        self.rotating: RotatingRecorder | None = None
        self.robots: dict[str, FoxgloveTelemetry] = {}
        self._states: dict[str, Callable[[], str]] = {}
        self._tickers: list[Callable[[], None]] = []
        self._log_handler: _LogHandler | None = None

    # --- sinks ----------------------------------------------------------------------------
    def serve(self, host: str, port: int) -> int:
        """Start the WebSocket server; returns the port it listens on (``port`` 0: any)."""
        try:
            self.server = foxglove.start_server(name=self.name, host=host, port=port,
                                                context=self.context)
        except Exception as exc:  # the SDK raises its own error for a taken port
            msg = f"live view on {host}:{port}: {exc}"
            raise VizError(msg) from exc
        bound = int(self.server.port)
        for feed in self.robots.values():  # a viewer gets each value as it comes
            feed.hold = False
            feed.flush()
        log.info("viz.serving", url=f"ws://{host}:{bound}")
        return bound

    def record(self, path: Path) -> None:
        """Record every channel to one MCAP file (``robotd sim --report DIR``: run.mcap)."""
        try:
            self._writer = open_recording(path, self.context)
        except (OSError, RuntimeError, ValueError) as exc:
            msg = f"recording to {path}: {exc}"
            raise VizError(msg) from exc

    def record_rotating(self, recorder: RotatingRecorder) -> None:
        """Record to size-bounded rotating files (``robotd run`` with ``[viz] record``)."""
        self.rotating = recorder
        recorder.start()

    @property
    def sinks(self) -> bool:
        return self.server is not None or self._writer is not None or self.rotating is not None

    # --- feeds ----------------------------------------------------------------------------
    def telemetry(self, robot: str) -> FoxgloveTelemetry:
        """The ``Telemetry`` a robot's behaviours publish through."""
        feed = self.robots.get(robot)
        if feed is None:
            # A recording alone takes the JSON values a second at a time (``tick``).
            feed = self.robots[robot] = FoxgloveTelemetry(
                self.context, robot if self.many else "", periods=self.periods,
                hold=self.server is None)
        return feed

    def watch_daemon(self, robot: str, daemon: Any) -> None:
        """Publish a daemon's state and events (``daemon.add_event_listener``)."""
        feed = self.telemetry(robot)
        self._states[robot] = lambda: str(daemon.state)
        daemon.add_event_listener(lambda event: _on_event(feed, event))

    def add_ticker(self, tick: Callable[[], None]) -> None:
        """Called every second on the loop (a simulator's truth, a late viewer's state)."""
        self._tickers.append(tick)

    def capture_logs(self) -> None:
        """Send the structured log (what the root logger lets through) to ``/log``."""
        if self._log_handler is None:
            self._log_handler = _LogHandler(LogChannel("/log", context=self.context))
            logging.getLogger().addHandler(self._log_handler)

    async def run(self) -> None:
        """The session's timer: state for late viewers, tickers, recording rotation."""
        while True:
            self.tick()
            await asyncio.sleep(_TICK_S)

    def tick(self) -> None:
        for robot, state in self._states.items():
            self.telemetry(robot).values("state", state=state())
        for tick in self._tickers:
            tick()
        self.flush()
        if self.rotating is not None:
            self.rotating.check()

    def flush(self) -> None:
        """Send what the robots' feeds hold (their JSON values while only recording)."""
        for feed in self.robots.values():
            feed.flush()

    def close(self) -> None:
        """Stop the server, finish the recordings, unhook the log (safe to call twice)."""
        self.flush()
        if self._log_handler is not None:
            logging.getLogger().removeHandler(self._log_handler)
            self._log_handler = None
        if self.server is not None:
            with contextlib.suppress(Exception):
                self.server.stop()
            self.server = None
        if self._writer is not None:
            with contextlib.suppress(Exception):
                self._writer.close()
            self._writer = None
        if self.rotating is not None:
            self.rotating.close()
            self.rotating = None


def _on_event(feed: FoxgloveTelemetry, event: dict[str, Any]) -> None:
    kind = str(event.get("kind", ""))
    if kind == "transition":
        feed.values("state", state=event.get("dst"), src=event.get("src"),
                    trigger=event.get("trigger"))
    feed.values("events", **event)


class _LogHandler(logging.Handler):
    """structlog's event dicts (and libraries' records) as Foxglove ``Log`` messages."""

    def __init__(self, channel: LogChannel) -> None:
        super().__init__()
        self.channel = channel

    def emit(self, record: logging.LogRecord) -> None:
        try:
            loop = asyncio.get_running_loop()
        except RuntimeError:
            return  # before or after the run: no loop time to log it at
        try:
            if not self.channel.has_sinks():
                return
            t_ns = int(loop.time() * 1e9)
            msg: Any = record.msg
            if isinstance(msg, dict):
                fields = {k: v for k, v in msg.items() if not k.startswith("_")}
                text = json_bytes(fields).decode()
            else:
                text = record.getMessage()
            self.channel.log(Log(timestamp=fm.stamp(t_ns),
                                 level=_LEVELS.get(record.levelno, LogLevel.Info),
                                 message=text, name=record.name, file=record.pathname,
                                 line=record.lineno), log_time=t_ns)
        except Exception:  # logging must never raise into the robot
            self.handleError(record)
