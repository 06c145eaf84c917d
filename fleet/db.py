"""Database access: one engine per URL, serialized write transactions, Alembic at start.

SQLite (WAL) is the default; PostgreSQL runs the same code. Every transaction that changes a
request or an assignment is *serialized*: on SQLite by one process-wide lock plus
``BEGIN IMMEDIATE``; on PostgreSQL by a transaction-scoped advisory lock, so several server
processes on one database never assign a robot twice.

On PostgreSQL every serialized transaction also sends ``NOTIFY fleet_changed`` (in the same
statement as its lock, so it costs no round trip and is delivered only if it commits): the
other server processes drop their copies of what it may have changed (``fleet.pg_listen``).
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import secrets
from collections.abc import AsyncIterator, Awaitable, Callable
from contextlib import asynccontextmanager
from typing import Any, TypeVar

import structlog
from alembic import command
from alembic.config import Config
from sqlalchemy import create_engine, event, text
from sqlalchemy.engine import Connection, Engine, make_url
from sqlalchemy.ext.asyncio import (
    AsyncConnection,
    AsyncEngine,
    AsyncSession,
    async_sessionmaker,
    create_async_engine,
)
from sqlalchemy.pool import StaticPool

from fleet.sqlite_inline import inline_connect

log = structlog.get_logger(__name__)

T = TypeVar("T")

_ADVISORY_LOCK_KEY = 0x726F_626F  # "robo"

CHANGED_CHANNEL = "fleet_changed"
"""PostgreSQL channel of committed changes; payload ``"<instance> <topic>[,<topic>...]"``."""
WRITE = "write"
"""Topic of every serialized transaction: requests or robots may have changed."""
SITE = "site"
"""Topic of a change of rooms, beacons, customers or settings (``fleet.cache.SiteCache``)."""
_CHANGED = "fleet.changed"
"""``session.info`` key: the topics ``announce`` added to a transaction."""


def announce(session: AsyncSession, topic: str) -> None:
    """Tell the other server processes, when this transaction commits, that ``topic``
    changed (e.g. ``"tokens"``: they drop their token snapshot). Nothing on SQLite."""
    session.info.setdefault(_CHANGED, set()).add(topic)


def normalize_url(url: str) -> str:
    """Accept plain ``sqlite:///`` and ``postgresql://`` URLs and pick the async drivers."""
    parsed = make_url(url)
    backend = parsed.get_backend_name()
    if backend == "sqlite":
        return parsed.set(drivername="sqlite+aiosqlite").render_as_string(hide_password=False)
    if backend in ("postgresql", "postgres"):
        return parsed.set(drivername="postgresql+asyncpg").render_as_string(hide_password=False)
    msg = f"unsupported database URL {url!r}: use sqlite:///PATH or postgresql://..."
    raise ValueError(msg)


DB_FILE_MODE = 0o600
"""The database holds token hashes and customers' data: its owner's only, whatever the umask
(SQLite gives its -wal and -shm files the database file's mode)."""


def restrict_sqlite_file(path: str) -> None:
    """Create the database file with ``DB_FILE_MODE`` if missing, tighten it if it is looser
    (made by an older version, or by hand), and refuse a symbolic link there (ValueError)."""
    try:
        fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_CLOEXEC, DB_FILE_MODE)
    except OSError as exc:
        reason = ("is a symbolic link: not opened through it" if os.path.islink(path)
                  else exc.strerror or str(exc))
        msg = f"database {path}: {reason}"
        raise ValueError(msg) from exc
    try:
        os.fchmod(fd, DB_FILE_MODE)
    finally:
        os.close(fd)
    for side in ("-wal", "-shm"):
        with contextlib.suppress(FileNotFoundError):
            fd = os.open(path + side, os.O_RDONLY | os.O_NOFOLLOW | os.O_CLOEXEC)
            try:
                os.fchmod(fd, DB_FILE_MODE)
            finally:
                os.close(fd)


def _sqlite_engine(url: str, begin: str | None, *, inline: bool = False) -> AsyncEngine:
    """``begin``: the statement that opens a transaction; None for autocommit reads (each
    statement its own snapshot, and no BEGIN/ROLLBACK round trips to aiosqlite's thread).
    ``inline``: connections run their calls on the loop's thread (``fleet.sqlite_inline``)."""
    database = make_url(url).database
    memory = database in (None, "", ":memory:")
    kwargs: dict[str, Any] = {"poolclass": StaticPool} if memory else {}
    if inline:
        path = database or ":memory:"
        kwargs["async_creator"] = lambda: inline_connect(path, timeout=30)
    if begin is None:
        kwargs["pool_reset_on_return"] = None
    if not memory:
        # Opening an aiosqlite connection starts a thread: keep them, never churn overflow.
        kwargs.update(pool_size=16 if begin is None else 4, max_overflow=0, pool_timeout=60)
    engine = create_async_engine(url, connect_args={"timeout": 30}, **kwargs)
    _set_up_sqlite(engine.sync_engine, begin, wal=not memory)
    return engine


def _sqlite_sync_engine(url: str, begin: str | None) -> Engine:
    """A synchronous engine on the same SQLite file as ``_sqlite_engine(url, begin)``, with
    the same connection set-up, for ``Database.run_read`` and ``run_write`` when SQLite runs
    inline: their functions run to the end on the loop's thread, so one connection serves
    them all (``StaticPool``)."""
    sync_url = make_url(url).set(drivername="sqlite+pysqlite")
    engine = create_engine(sync_url, connect_args={"timeout": 30}, poolclass=StaticPool,
                           pool_reset_on_return=None if begin is None else "rollback")
    _set_up_sqlite(engine, begin, wal=True)
    return engine


def _set_up_sqlite(engine: Engine, begin: str | None, *, wal: bool) -> None:
    @event.listens_for(engine, "connect")
    def _on_connect(dbapi_connection: Any, _record: Any) -> None:
        # Let SQLAlchemy's "begin" event (below) emit BEGIN, not the driver.
        dbapi_connection.isolation_level = None
        cursor = dbapi_connection.cursor()
        if wal:
            cursor.execute("PRAGMA journal_mode=WAL")
        cursor.execute("PRAGMA synchronous=NORMAL")
        cursor.execute("PRAGMA foreign_keys=ON")
        cursor.execute("PRAGMA busy_timeout=30000")
        cursor.close()

    if begin is not None:
        statement = begin

        @event.listens_for(engine, "begin")
        def _on_begin(conn: Connection) -> None:
            conn.exec_driver_sql(statement)


async def _as_async_close() -> None:
    """The loop turns an async connection's or session's close takes (SQLAlchemy closes it in
    a task of its own and waits for that: three callbacks, none of which waits for I/O with
    inline SQLite), so that requests at one instant interleave with the other tasks as they
    do through the async engines, and a simulation's events stay the same."""
    for _ in range(3):
        await asyncio.sleep(0)


_LOCK_AND_NOTIFY = text("SELECT pg_advisory_xact_lock(:key), pg_notify(:channel, :payload)")
_NOTIFY = text("SELECT pg_notify(:channel, :payload)")


class Database:
    """The engines and sessions of one database URL.

    ``inline_sqlite``: SQLite calls run on the loop's thread instead of aiosqlite's worker
    threads (a single-process server on a local file; see ``fleet.sqlite_inline``), and the
    functions given to ``run_read`` and ``run_write`` run on synchronous connections.
    """

    def __init__(self, url: str, *, inline_sqlite: bool = False) -> None:
        self.url = normalize_url(url)
        self.dialect = make_url(self.url).get_backend_name()
        self._write_lock = asyncio.Lock()
        # Counts serialized write transactions of this process (caches of rows compare it).
        self.generation = 0
        # Called with the session after each ``write()`` transaction commits (what it added is
        # in ``session.info``, e.g. the notifications ``fleet.push`` delivers).
        self.after_commit: list[Callable[[AsyncSession], None]] = []
        # PostgreSQL: awaited with the session of each ``write()`` transaction right before it
        # commits (``fleet.pg_listen`` sends the NOTIFY of the notifications it created).
        self.before_commit: list[Callable[[AsyncSession], Awaitable[None]]] = []
        # Names this process in the NOTIFYs it sends, so that it can skip its own.
        self.instance = f"{os.getpid()}.{secrets.token_hex(3)}"
        # With inline SQLite on a file: run_read's and run_write's synchronous engines.
        self._sync_read: Engine | None = None
        self._sync_write: Engine | None = None
        if self.dialect == "sqlite":
            if make_url(self.url).database in (None, "", ":memory:"):
                self.read_engine = self.write_engine = _sqlite_engine(
                    self.url, "BEGIN", inline=inline_sqlite)
            else:
                restrict_sqlite_file(str(make_url(self.url).database))
                self.read_engine = _sqlite_engine(self.url, None, inline=inline_sqlite)
                self.write_engine = _sqlite_engine(self.url, "BEGIN IMMEDIATE",
                                                   inline=inline_sqlite)
                if inline_sqlite:
                    self._sync_read = _sqlite_sync_engine(self.url, None)
                    self._sync_write = _sqlite_sync_engine(self.url, "BEGIN IMMEDIATE")
        else:
            self.read_engine = create_async_engine(self.url, pool_size=10, max_overflow=20)
            self.write_engine = self.read_engine
        self._reads = async_sessionmaker(self.read_engine, expire_on_commit=False)
        self._writes = async_sessionmaker(self.write_engine, expire_on_commit=False)

    @asynccontextmanager
    async def read(self) -> AsyncIterator[AsyncSession]:
        """A read-only session (on SQLite each statement reads its own snapshot)."""
        async with self._reads() as session:
            yield session

    @asynccontextmanager
    async def read_connection(self) -> AsyncIterator[AsyncConnection]:
        """A Core connection for hot read paths (cheaper than an ORM session)."""
        async with self.read_engine.connect() as conn:
            yield conn

    async def run_read(self, read: Callable[[Connection], T]) -> T:
        """``read(conn)`` on a Core connection of the read engine (a hot read written as one
        plain function of a connection). With inline SQLite it runs on a synchronous
        connection: no greenlet and no await per statement, each of which costs more than
        SQLite's own work (~100 us a read); otherwise in one ``run_sync`` greenlet."""
        if self._sync_read is not None:
            with self._sync_read.connect() as conn:
                result = read(conn)
            await _as_async_close()
            return result
        async with self.read_engine.connect() as conn:
            return await conn.run_sync(read)

    async def run_write(self, write: Callable[[Connection], T], *, serial: bool = True) -> T:
        """``write(conn)`` in a transaction as ``write()`` opens it (the same lock, BEGIN and
        commit), on a Core connection; synchronous with inline SQLite, as ``run_read``."""
        if self._sync_write is None:
            async with self.write(serial=serial) as session:
                return await (await session.connection()).run_sync(write)
        try:
            async with self._write_lock:
                with self._sync_write.begin() as conn:
                    result = write(conn)
                await _as_async_close()
                return result
        finally:
            if serial:
                self.generation += 1

    @asynccontextmanager
    async def write(self, *, serial: bool = True) -> AsyncIterator[AsyncSession]:
        """A transaction committed at the end; ``serial`` ones run one at a time site-wide."""
        try:
            if self.dialect == "sqlite":
                async with self._write_lock, self._writes() as session:
                    async with session.begin():
                        yield session
                    self._committed(session)
                return
            async with self._writes() as session:
                async with session.begin():
                    if serial:
                        await session.execute(_LOCK_AND_NOTIFY, {
                            "key": _ADVISORY_LOCK_KEY, "channel": CHANGED_CHANNEL,
                            "payload": f"{self.instance} {WRITE}"})
                    yield session
                    await self._before_commit(session)
                self._committed(session)
        finally:
            if serial:
                self.generation += 1

    async def _before_commit(self, session: AsyncSession) -> None:
        topics: set[str] | None = session.info.get(_CHANGED)
        if topics:
            await session.execute(_NOTIFY, {
                "channel": CHANGED_CHANNEL,
                "payload": f"{self.instance} {','.join(sorted(topics))}"})
        for hook in self.before_commit:
            await hook(session)

    def _committed(self, session: AsyncSession) -> None:
        """Tell the ``after_commit`` listeners (they must not raise or block)."""
        for listener in self.after_commit:
            try:
                listener(session)
            except Exception:
                log.exception("fleet.db.after_commit_failed")

    async def migrate(self) -> None:
        """Bring the schema to the newest migration."""
        cfg = Config()
        cfg.set_main_option("script_location", "fleet:migrations")
        cfg.set_main_option("sqlalchemy.url", self.url)

        def upgrade(connection: Connection) -> None:
            cfg.attributes["connection"] = connection
            command.upgrade(cfg, "head")

        async with self.write_engine.begin() as conn:
            if self.dialect != "sqlite":
                await conn.execute(
                    text("SELECT pg_advisory_xact_lock(:key)"), {"key": _ADVISORY_LOCK_KEY})
            await conn.run_sync(upgrade)
        log.info("fleet.db.migrated", dialect=self.dialect)

    async def dispose(self) -> None:
        for engine in (self._sync_read, self._sync_write):
            if engine is not None:
                engine.dispose()
        await self.read_engine.dispose()
        if self.write_engine is not self.read_engine:
            await self.write_engine.dispose()
