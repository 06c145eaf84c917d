"""``robotd run`` with the live view: the session from ``[viz]``, run beside the daemon.

On the robot the live view is an aid, never a reason not to run: a port that is taken or a
state directory that cannot hold a recording is logged, and the robot runs without it.
"""

from __future__ import annotations

import asyncio
from pathlib import Path
from typing import Any

import structlog

from hal.ports import WallClock
from hal.settings import SettingsView
from hal.tasks import cancel_and_wait
from hal.telemetry import NULL_TELEMETRY, Telemetry
from robotd.viz.config import VizConfig
from robotd.viz.recorder import RotatingRecorder
from robotd.viz.session import VizError, VizSession

log = structlog.get_logger(__name__)

RECORDINGS = "viz"
"""The recordings' folder in the state directory."""


def open_daemon_viz(settings: SettingsView, state_dir: Path,
                    wall_clock: WallClock) -> VizSession | None:
    """The session ``[viz]`` asks for (serving, recording or both), or None when off."""
    config = VizConfig.from_settings(settings)
    if not config.enabled and not config.record:
        return None
    session = VizSession(f"robotd {settings.get('robot.name')}")
    if config.enabled:
        try:
            session.serve(config.host, config.port)
        except VizError as exc:
            log.error("viz.serve_failed", error=str(exc))
    if config.record:
        session.record_rotating(RotatingRecorder(
            state_dir / RECORDINGS, session.context, max_bytes=config.record_max_bytes,
            keep=config.record_files, wall_clock=wall_clock))
    if not session.sinks:
        session.close()
        return None
    session.capture_logs()
    return session


def telemetry_of(session: VizSession | None, robot: str) -> Telemetry:
    return session.telemetry(robot) if session is not None else NULL_TELEMETRY


async def run_daemon(daemon: Any, session: VizSession | None) -> int:
    """``daemon.run()`` with the session's timer beside it; the session closed after."""
    if session is None:
        code: int = await daemon.run()
        return code
    session.watch_daemon(str(daemon.settings.get("robot.name")), daemon)
    timer = asyncio.create_task(session.run(), name="viz")
    try:
        code = await daemon.run()
        return code
    finally:
        await cancel_and_wait(timer)
        session.close()
