"""Several server processes on one PostgreSQL database: what one tells the others, and which
one runs the site's sweeps.

``PgListener`` holds one connection of its own per server process (``application_name``
``robotd-fleet PID``) and on it:

- ``LISTEN fleet_notification``: every transaction that creates notifications sends
  ``NOTIFY fleet_notification, '<id>'`` for each, in that transaction (``notify_created``,
  a ``Database.before_commit`` hook), so it is heard only once committed. The listener wakes
  the ``EventHub``, which reads the table in id order as before: a NOTIFY is only a wake-up,
  and after a lost connection the hub catches up from its last id.
- ``LISTEN fleet_changed``: every serialized transaction says it committed (``fleet.db``),
  token changes say so too; the other processes drop their snapshots at once instead of
  after their time to live.
- the site's leader lock: a session advisory lock (``LEADER_LOCK_KEY``). The process that
  holds it runs the timeout and offline sweeps; the others try for it before each of their
  passes. When the holder dies its connection closes, PostgreSQL releases the lock, and the
  next process to try takes over. (Were two ever to sweep at once, e.g. across a network
  partition that PostgreSQL has not noticed yet, nothing breaks: each pass is a serialized
  transaction that reads the rows afresh and acts only on what is still due.)

A lost connection is retried with a growing delay (0.2 s to 5 s); it is checked every
``CHECK_S`` with a query, so a dead peer is noticed even when the socket says nothing.
"""

from __future__ import annotations

import asyncio
import contextlib
import os
from collections.abc import Callable
from typing import Any

import asyncpg  # type: ignore[import-untyped]
import structlog
from sqlalchemy import text
from sqlalchemy.engine import make_url
from sqlalchemy.ext.asyncio import AsyncSession

from fleet.db import CHANGED_CHANNEL, Database
from fleet.models import Notification
from fleet.services.notify import CREATED

log = structlog.get_logger(__name__)

NOTIFICATION_CHANNEL = "fleet_notification"
LEADER_LOCK_KEY = 0x726F_626F_6C65_6164  # "roboleed": the sweeps' lock, not the writers'
CHECK_S = 5.0
RETRY_MIN_S = 0.2
RETRY_MAX_S = 5.0

_NOTIFY_IDS = text(
    "SELECT pg_notify(:channel, id) FROM unnest(string_to_array(:ids, ',')) AS id")


async def notify_created(session: AsyncSession) -> None:
    """Before commit: one NOTIFY per notification the transaction created (payload: its id)."""
    created: list[Notification] = session.info.get(CREATED) or []
    if not created:
        return
    await session.flush()
    await session.execute(_NOTIFY_IDS, {
        "channel": NOTIFICATION_CHANNEL, "ids": ",".join(str(row.id) for row in created)})


class PgListener:
    """Args:
        db: the fleet database (PostgreSQL).
        on_notification: called with a notification's id as one is committed (any process).
        on_changed: called with the topics another process's commit changed
            (``fleet.db.WRITE``, ``fleet.tokens.TOKENS``).
        on_connected: called on every (re)connection: what was missed meanwhile must be
            read again.
    """

    def __init__(self, db: Database, *, on_notification: Callable[[int], None],
                 on_changed: Callable[[set[str]], None],
                 on_connected: Callable[[], None]) -> None:
        self._db = db
        self._dsn = make_url(db.url).set(drivername="postgresql").render_as_string(
            hide_password=False)
        self._on_notification = on_notification
        self._on_changed = on_changed
        self._on_connected = on_connected
        self._conn: Any = None
        self._query_lock = asyncio.Lock()
        self._task: asyncio.Task[None] | None = None
        self._first = asyncio.Event()
        self.leading = False
        self.connections = 0
        db.before_commit.append(notify_created)

    async def start(self, first_wait_s: float = 5.0) -> None:
        """Start listening; waits (bounded) for the first connection."""
        self._task = asyncio.create_task(self._run())
        with contextlib.suppress(TimeoutError):
            await asyncio.wait_for(self._first.wait(), first_wait_s)

    async def stop(self) -> None:
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task
            self._task = None

    async def lead(self) -> bool:
        """Whether this process runs the site's sweeps now (it takes the lock if it is free)."""
        conn = self._conn
        if conn is None or conn.is_closed():
            return False
        if self.leading:
            return True
        try:
            async with self._query_lock:
                got = await asyncio.wait_for(
                    conn.fetchval("SELECT pg_try_advisory_lock($1)", LEADER_LOCK_KEY), CHECK_S)
        except (asyncpg.PostgresError, asyncpg.InterfaceError, OSError, TimeoutError) as exc:
            log.warning("fleet.leader.try_failed", error=f"{type(exc).__name__}: {exc}")
            return False
        if got and conn is self._conn:
            self.leading = True
            log.info("fleet.leader.acquired", pid=os.getpid())
        return self.leading

    async def _run(self) -> None:
        delay = RETRY_MIN_S
        while True:
            try:
                conn = await self._connect()
            except (asyncpg.PostgresError, asyncpg.InterfaceError, OSError,
                    TimeoutError) as exc:
                log.warning("fleet.listen.connect_failed", error=f"{type(exc).__name__}: {exc}",
                            retry_s=delay)
                await asyncio.sleep(delay)
                delay = min(delay * 2, RETRY_MAX_S)
                continue
            delay = RETRY_MIN_S
            self._conn = conn
            self.connections += 1
            log.info("fleet.listen.connected", connections=self.connections)
            self._first.set()
            self._on_connected()
            try:
                await self._watch(conn)
            finally:
                self._conn = None
                if self.leading:
                    self.leading = False
                    log.warning("fleet.leader.lost", pid=os.getpid())
                if not conn.is_closed():
                    conn.terminate()
            log.warning("fleet.listen.lost")

    async def _connect(self) -> Any:
        conn = await asyncpg.connect(
            self._dsn, timeout=CHECK_S,
            server_settings={"application_name": f"robotd-fleet {os.getpid()}"})
        try:
            await conn.add_listener(NOTIFICATION_CHANNEL, self._notification)
            await conn.add_listener(CHANGED_CHANNEL, self._changed)
        except BaseException:
            conn.terminate()
            raise
        return conn

    async def _watch(self, conn: Any) -> None:
        """Returns when the connection is lost."""
        lost = asyncio.Event()
        conn.add_termination_listener(lambda _c: lost.set())
        while not lost.is_set():
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(lost.wait(), CHECK_S)
            if lost.is_set():
                return
            try:
                async with self._query_lock:
                    await asyncio.wait_for(conn.fetchval("SELECT 1"), CHECK_S)
            except (asyncpg.PostgresError, asyncpg.InterfaceError, OSError,
                    TimeoutError) as exc:
                log.warning("fleet.listen.check_failed", error=f"{type(exc).__name__}: {exc}")
                return

    def _notification(self, _conn: Any, _pid: int, _channel: str, payload: str) -> None:
        try:
            notification_id = int(payload)
        except ValueError:
            log.warning("fleet.listen.bad_payload", channel=NOTIFICATION_CHANNEL,
                        payload=payload[:100])
            return
        self._on_notification(notification_id)

    def _changed(self, _conn: Any, _pid: int, _channel: str, payload: str) -> None:
        instance, _, topics = payload.partition(" ")
        if instance != self._db.instance:
            self._on_changed(set(topics.split(",")))
