"""Crash-safe mission state: JSON values by key in SQLite (WAL) under the state directory.

Reads come from memory (restored at start); writes are applied in memory at once and made
durable by a writer task, so a slow SD card never stalls the event loop.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import sqlite3
from collections.abc import Callable
from pathlib import Path
from typing import Any

import structlog

from hal.files import restrict_new

log = structlog.get_logger(__name__)

_SCHEMA = """
CREATE TABLE IF NOT EXISTS kv (
    key TEXT PRIMARY KEY,
    value TEXT NOT NULL
)
"""
_DELETED = object()


class StateStore:
    """Key -> JSON-able value, surviving restarts and power loss (WAL, synchronous=FULL).

    ``name``/``critical``/``depends_on``/``run`` make it a supervised service: the writer.
    """

    name = "store"
    critical = True
    depends_on: tuple[str, ...] = ()

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        restrict_new(self.path, 0o600)  # mission state: the robot's alone, whatever the umask
        # The connection moves to the executor thread for writes; one writer at a time.
        self._db = sqlite3.connect(self.path, isolation_level=None, check_same_thread=False)
        self._db.execute("PRAGMA journal_mode=WAL")
        self._db.execute("PRAGMA synchronous=FULL")
        self._db.execute(_SCHEMA)
        self._values: dict[str, Any] = {}
        self._dirty: dict[str, Any] = {}
        self._wake = asyncio.Event()
        self._inflight: asyncio.Future[None] | None = None
        self._flushing: asyncio.Lock | None = None
        self._closed = False
        self._restore()

    def _restore(self) -> None:
        for key, text in self._db.execute("SELECT key, value FROM kv"):
            try:
                self._values[key] = json.loads(text)
            except json.JSONDecodeError:
                log.warning("store.corrupt_value", key=key, path=str(self.path))
        log.info("store.restored", path=str(self.path), keys=len(self._values))

    def get(self, key: str, default: Any = None) -> Any:
        return self._values.get(key, default)

    def put(self, key: str, value: Any) -> None:
        """Keep ``value`` (anything JSON can hold) under ``key``; ValueError when it cannot."""
        try:
            text = json.dumps(value)
        except (TypeError, ValueError) as exc:
            msg = f"store: {key}: value is not JSON-able: {exc}"
            raise ValueError(msg) from exc
        self._values[key] = json.loads(text)
        self._dirty[key] = text
        self._wake.set()

    def delete(self, key: str) -> None:
        if self._values.pop(key, None) is not None or key in self._dirty:
            self._dirty[key] = _DELETED
            self._wake.set()

    def keys(self, prefix: str = "") -> list[str]:
        return sorted(k for k in self._values if k.startswith(prefix))

    def _write(self, batch: dict[str, Any]) -> None:
        with self._db:
            self._db.execute("BEGIN")
            for key, text in batch.items():
                if text is _DELETED:
                    self._db.execute("DELETE FROM kv WHERE key = ?", (key,))
                else:
                    self._db.execute(
                        "INSERT INTO kv(key, value) VALUES (?, ?) "
                        "ON CONFLICT(key) DO UPDATE SET value = excluded.value",
                        (key, text),
                    )

    def _take_batch(self) -> dict[str, Any]:
        batch, self._dirty = self._dirty, {}
        self._wake.clear()
        return batch

    async def flush(self) -> None:
        """Make every value put so far durable (committed, fsynced) before returning.

        Callers that must not acknowledge something before it is on disk (the e-stop latch)
        await this; flushes queue one behind another, so two never write at once.
        """
        if self._closed:
            self._take_batch()  # never written: the store was closed or abandoned
            return
        if self._flushing is None:
            self._flushing = asyncio.Lock()
        async with self._flushing:
            if self._inflight is not None and not self._inflight.done():
                await asyncio.shield(self._inflight)
            batch = self._take_batch()
            if batch and not self._closed:
                # sqlite3 has no asyncio API and fsync on an SD card can take tens of ms.
                loop = asyncio.get_running_loop()
                self._inflight = loop.run_in_executor(None, self._write, batch)
                # Shielded: a cancelled writer task still lets the batch reach the disk.
                await asyncio.shield(self._inflight)

    async def run(self, ready: Callable[[], None]) -> None:
        ready()
        while True:
            await self._wake.wait()
            await self.flush()

    async def aclose(self) -> None:
        """Wait for a write under way, write what is pending, close."""
        if self._inflight is not None and not self._inflight.done():
            with contextlib.suppress(Exception):
                await self._inflight
        self.close()

    def close(self) -> None:
        """Write what is pending and close (no write may be under way); safe to call twice."""
        if self._closed:
            return
        batch = self._take_batch()
        if batch:
            self._write(batch)
        with contextlib.suppress(sqlite3.Error):
            self._db.execute("PRAGMA wal_checkpoint(TRUNCATE)")
        self._db.close()
        self._closed = True

    def abandon(self) -> None:
        """Drop what is not written yet and stop writing, as a SIGKILL or a power cut would.

        For the simulator's ``robot.kill``: a write already handed to SQLite finishes (or
        not) on its own, as in a killed process; nothing else reaches the disk.
        """
        self._dirty.clear()
        self._closed = True
        if self._inflight is not None and not self._inflight.done():
            self._inflight.add_done_callback(lambda _f: self._db.close())
        else:
            self._db.close()
