"""MCAP recordings of a Foxglove context: one file, or size-bounded rotating files.

The SDK's MCAP writer is a sink of the context: every channel logged on the context is written
with its ``log_time`` (the event loop's time). ``RotatingRecorder`` starts a new file once the
current one passes ``max_bytes`` and deletes the oldest beyond ``keep`` files; the size is
checked by ``check()`` (the session calls it every few seconds), as the writer itself only
knows chunks. A file that cannot be opened is logged and recording stops; the robot runs on.
"""

from __future__ import annotations

from collections.abc import Callable
from datetime import datetime
from pathlib import Path

import foxglove
import structlog
from foxglove.mcap import MCAPCompression, MCAPWriteOptions, MCAPWriter

log = structlog.get_logger(__name__)

PROFILE = "robotd"
"""The MCAP header's profile (no ROS message definitions: Foxglove's own schemas)."""


def open_recording(path: Path, context: foxglove.Context) -> MCAPWriter:
    """A writer to ``path`` (replaced when it exists) on ``context``."""
    path.parent.mkdir(parents=True, exist_ok=True)
    # LZ4 rather than the default zstd: cheaper on the CPU for larger files (docs/live-view.md
    # has bench/bench_mcap.py's figures), what keeps the recording's cost on the simulator small.
    options = MCAPWriteOptions(profile=PROFILE, compression=MCAPCompression.Lz4)
    return foxglove.open_mcap(path, allow_overwrite=True, context=context,
                              writer_options=options)


class RotatingRecorder:
    """Recordings in ``directory`` named by the wall-clock time each began.

    Args:
        directory: where the files go (made if missing).
        context: the context whose channels are recorded.
        max_bytes: past this size the file is closed and a new one begun.
        keep: files kept, the current one included; older ones are deleted.
        wall_clock: names the files (``robotd-20260101T120000.mcap``).
    """

    def __init__(self, directory: Path, context: foxglove.Context, *, max_bytes: int,
                 keep: int, wall_clock: Callable[[], datetime]) -> None:
        self.directory = directory
        self.context = context
        self.max_bytes = max_bytes
        self.keep = keep
        self.wall_clock = wall_clock
        self.path: Path | None = None
        self._writer: MCAPWriter | None = None
        self.files_started = 0

    def start(self) -> bool:
        """Begin a new file; False (logged) when it cannot be opened."""
        self.close()
        stamp = self.wall_clock().strftime("%Y%m%dT%H%M%S")
        path = self.directory / f"robotd-{stamp}-{self.files_started:04d}.mcap"
        try:
            self._writer = open_recording(path, self.context)
        except (OSError, RuntimeError, ValueError) as exc:
            log.error("viz.record_failed", path=str(path), error=str(exc))
            return False
        self.path = path
        self.files_started += 1
        log.info("viz.recording", path=str(path), max_bytes=self.max_bytes)
        self._prune()
        return True

    def check(self) -> None:
        """Rotate when the current file has grown past ``max_bytes``."""
        if self.path is None:
            return
        try:
            size = self.path.stat().st_size
        except OSError:
            size = 0
        if size >= self.max_bytes:
            self.start()

    def close(self) -> None:
        if self._writer is not None:
            try:
                self._writer.close()
            except Exception as exc:  # a full disk must not stop the robot
                log.warning("viz.record_close_failed", path=str(self.path), error=repr(exc))
            self._writer = None

    def _prune(self) -> None:
        files = sorted(self.directory.glob("robotd-*.mcap"))
        for old in files[:-self.keep]:
            try:
                old.unlink()
            except OSError as exc:
                log.warning("viz.record_prune_failed", path=str(old), error=str(exc))
