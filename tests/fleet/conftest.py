"""Fixtures: every fleet test runs on SQLite and, where a server can be started, PostgreSQL."""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator, Awaitable, Callable, Iterator
from pathlib import Path
from typing import Any

import asyncpg
import hypothesis_profile  # noqa: F401  (the settings every test folder shares)
import pytest
from fleet_harness import Fleet
from pgtest import PgCluster, PgUnavailable

from fleet.db import Database
from fleet.models import Base

PG_DATABASE = "fleet_test"


@pytest.fixture(scope="session")
def pg_cluster() -> Iterator[PgCluster | str]:
    """A throwaway PostgreSQL cluster with a migrated database, or the reason there is none."""
    try:
        cluster = PgCluster.start()
    except PgUnavailable as exc:
        print(f"\nPostgreSQL tests skipped: {exc}")
        yield str(exc)
        return
    asyncio.run(_migrated(cluster))
    yield cluster
    cluster.stop()


async def _migrated(cluster: PgCluster) -> None:
    db = Database(await cluster.create_database(PG_DATABASE))
    await db.migrate()
    await db.dispose()


async def _emptied(cluster: PgCluster) -> str:
    """The session's PostgreSQL database, emptied (faster than a new database per test)."""
    conn = await asyncpg.connect(host="127.0.0.1", port=cluster.port, user="postgres",
                                 database=PG_DATABASE)
    try:
        await conn.execute(f"TRUNCATE {', '.join(Base.metadata.tables)} RESTART IDENTITY CASCADE")
    finally:
        await conn.close()
    return cluster.url(PG_DATABASE)


MakeFleet = Callable[..., Awaitable[Fleet]]


@pytest.fixture(params=["sqlite", pytest.param("postgres", marks=pytest.mark.postgres)])
async def db_url(
    request: pytest.FixtureRequest, tmp_path: Path, pg_cluster: PgCluster | str
) -> str:
    if request.param == "sqlite":
        return f"sqlite:///{tmp_path / 'fleet.db'}"
    if isinstance(pg_cluster, str):
        pytest.skip(f"no PostgreSQL server: {pg_cluster}")
    return await _emptied(pg_cluster)


@pytest.fixture
async def make_fleet(db_url: str) -> AsyncIterator[MakeFleet]:
    """Builds started fleets on the test's database (settings as PascalCase keys)."""
    made: list[Fleet] = []

    async def make(**settings: Any) -> Fleet:
        fleet = Fleet(db_url, settings=settings or None)
        await fleet.__aenter__()
        made.append(fleet)
        return fleet

    yield make
    for fleet in made:
        await fleet.__aexit__(None, None, None)


@pytest.fixture
async def fleet(make_fleet: MakeFleet) -> Fleet:
    return await make_fleet()
