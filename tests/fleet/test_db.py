"""``Database.run_read`` and ``run_write``: inline SQLite's synchronous connections read and
write what the async engines do, and let the other tasks run as the async engines do."""

from __future__ import annotations

import asyncio
import os
import stat
from collections.abc import AsyncIterator, Callable
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from sqlalchemy import Connection, delete, insert, select, text

from fleet.db import Database, restrict_sqlite_file
from fleet.models import Robot

ORIGIN = datetime(2026, 1, 5, 8, 0, tzinfo=UTC)

robots = st.lists(st.fixed_dictionaries({
    "name": st.text(st.characters(codec="utf-8", exclude_categories=["Cs"]), min_size=1,
                    max_size=12),
    "is_offline": st.booleans(),
    "last_ping_at": st.none() | st.integers(0, 10**9).map(
        lambda us: ORIGIN + timedelta(microseconds=us)),
    "weight_kg": st.none() | st.floats(allow_nan=False, allow_infinity=False),
}), max_size=6, unique_by=lambda r: r["name"])


def read_robots(conn: Connection) -> list[tuple[Any, ...]]:
    return [tuple(row) for row in conn.execute(
        select(Robot.id, Robot.name, Robot.is_offline, Robot.last_ping_at, Robot.weight_kg)
        .order_by(Robot.id))]


@pytest.fixture
async def dbs(tmp_path: Path) -> AsyncIterator[tuple[Database, Database]]:
    """The same file through inline SQLite and through aiosqlite's threads."""
    url = f"sqlite:///{tmp_path / 'fleet.db'}"
    inline, threaded = Database(url, inline_sqlite=True), Database(url)
    await threaded.migrate()
    yield inline, threaded
    await inline.dispose()
    await threaded.dispose()


async def callbacks_during(action: Callable[[], Any]) -> int:
    """How many times a task that only yields ran while ``action`` was awaited."""
    ticks = 0

    async def ticker() -> None:
        nonlocal ticks
        while True:
            ticks += 1
            await asyncio.sleep(0)

    task = asyncio.create_task(ticker())
    await asyncio.sleep(0)
    before = ticks
    await action()
    during = ticks - before
    task.cancel()
    return during


class TestRunRead:
    @given(rows=robots)
    @settings(max_examples=40, deadline=None,
              suppress_health_check=[HealthCheck.function_scoped_fixture])
    async def test_inline_sqlite_reads_what_the_async_engine_reads(self, dbs, rows):
        """Rows written by either engine read back equal (types, time zones, floats) through
        the synchronous connection and through the async engine's connection."""
        inline, threaded = dbs
        async with threaded.write() as session:
            await session.execute(delete(Robot))
            if rows:
                await session.execute(insert(Robot), rows)
        async with threaded.read_connection() as conn:
            expected = await conn.run_sync(read_robots)
        assert await inline.run_read(read_robots) == expected
        assert await threaded.run_read(read_robots) == expected
        assert [r[1] for r in expected] == [r["name"] for r in rows]

    async def test_an_error_in_the_read_reaches_the_caller(self, dbs):
        """The function's exception is raised to the caller, and the next read works."""
        inline, _ = dbs

        def failing(conn: Connection) -> None:
            conn.execute(select(Robot.id)).all()
            msg = "no such robot"
            raise LookupError(msg)

        with pytest.raises(LookupError, match="no such robot"):
            await inline.run_read(failing)
        assert await inline.run_read(read_robots) == []

    async def test_a_read_lets_other_tasks_run_as_the_async_connection_does(self, dbs):
        """Tasks ready at the same instant run as many times during an inline read as during
        the async engine's, so requests interleave as they did (a simulation's events stay
        the same)."""
        inline, _ = dbs
        async_engine = inline.read_engine

        async def through_async_connection() -> None:
            async with async_engine.connect() as conn:
                await conn.run_sync(read_robots)

        expected = await callbacks_during(through_async_connection)
        assert expected > 0
        assert await callbacks_during(lambda: inline.run_read(read_robots)) == expected


class TestRunWrite:
    async def test_a_write_is_committed_and_read_by_both_engines(self, dbs):
        """What the synchronous connection writes, the async engines read."""
        inline, threaded = dbs

        def add(conn: Connection) -> int:
            conn.execute(insert(Robot), [{"name": "r1"}, {"name": "r2"}])
            return 2

        assert await inline.run_write(add) == 2
        names = [row[1] for row in await threaded.run_read(read_robots)]
        assert names == ["r1", "r2"]
        assert await inline.run_read(read_robots) == await threaded.run_read(read_robots)

    @pytest.mark.parametrize("inline_sqlite", [True, False])
    async def test_a_failed_write_changes_nothing(self, dbs, inline_sqlite):
        """An exception in the function rolls the whole transaction back."""
        db = dbs[0] if inline_sqlite else dbs[1]

        def half(conn: Connection) -> None:
            conn.execute(insert(Robot), [{"name": "r1"}])
            msg = "stop"
            raise RuntimeError(msg)

        with pytest.raises(RuntimeError, match="stop"):
            await db.run_write(half)
        assert await db.run_read(read_robots) == []

    @pytest.mark.parametrize("inline_sqlite", [True, False])
    async def test_only_serial_writes_count_a_generation(self, dbs, inline_sqlite):
        """Caches of rows compare ``generation``: a serial write moves it, a plain one not."""
        db = dbs[0] if inline_sqlite else dbs[1]
        before = db.generation
        await db.run_write(lambda conn: conn.execute(insert(Robot), [{"name": "a"}]),
                           serial=False)
        assert db.generation == before
        await db.run_write(lambda conn: conn.execute(insert(Robot), [{"name": "b"}]))
        assert db.generation == before + 1

    async def test_a_write_waits_for_the_write_in_progress(self, dbs):
        """The synchronous write takes the same lock as ``write()``: it runs after the
        transaction in progress has committed, not inside it."""
        inline, _ = dbs
        order: list[str] = []

        async def session_write() -> None:
            async with inline.write() as session:
                await session.execute(insert(Robot), [{"name": "first"}])
                order.append("session")
                await asyncio.sleep(0.01)

        def sync_write(conn: Connection) -> None:
            order.append("sync")
            conn.execute(insert(Robot), [{"name": "second"}])

        first = asyncio.create_task(session_write())
        await asyncio.sleep(0)
        await inline.run_write(sync_write)
        await first
        assert order == ["session", "sync"]
        assert [r[1] for r in await inline.run_read(read_robots)] == ["first", "second"]

    async def test_a_write_lets_other_tasks_run_as_a_session_does(self, dbs):
        """As for reads: as many turns of the other ready tasks as the async session's."""
        inline, _ = dbs

        async def through_session() -> None:
            async with inline.write(serial=False) as session:
                await (await session.connection()).run_sync(read_robots)

        expected = await callbacks_during(through_session)
        assert await callbacks_during(
            lambda: inline.run_write(read_robots, serial=False)) == expected


class TestTheDatabaseFile:
    """Issue 28: fleet.db holds token hashes and customers' data; it was 0644 outside
    systemd (the umask's doing)."""

    async def test_it_is_its_owners_only_whatever_the_umask(self, tmp_path: Path) -> None:
        path = tmp_path / "fleet.db"
        old = os.umask(0o000)
        try:
            db = Database(f"sqlite:///{path}")
            await db.migrate()
            async with db.write() as session:
                await session.execute(text("SELECT 1"))
            await db.dispose()
        finally:
            os.umask(old)
        modes = {name: stat.S_IMODE(os.stat(tmp_path / name).st_mode)
                 for name in os.listdir(tmp_path)}
        assert "fleet.db" in modes
        assert modes == dict.fromkeys(modes, 0o600)

    def test_a_looser_file_is_tightened_and_a_link_refused(self, tmp_path: Path) -> None:
        path = tmp_path / "fleet.db"
        path.touch(mode=0o666)
        os.chmod(path, 0o666)
        restrict_sqlite_file(str(path))
        assert stat.S_IMODE(path.stat().st_mode) == 0o600
        link = tmp_path / "link.db"
        link.symlink_to(tmp_path / "elsewhere.db")
        with pytest.raises(ValueError, match=f"database {link}: is a symbolic link"):
            Database(f"sqlite:///{link}")
        assert not (tmp_path / "elsewhere.db").exists()
