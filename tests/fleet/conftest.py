"""Fixtures: every fleet test runs on SQLite and, where a server can be started, PostgreSQL."""

from __future__ import annotations

import itertools
from collections.abc import AsyncIterator, Awaitable, Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from fleet.pgtest import PgCluster, PgUnavailable
from fleet_harness import Fleet

_names = itertools.count()


@pytest.fixture(scope="session")
def pg_cluster() -> Iterator[PgCluster | str]:
    """A throwaway PostgreSQL cluster for the session, or the reason there is none."""
    try:
        cluster = PgCluster.start()
    except PgUnavailable as exc:
        print(f"\nPostgreSQL tests skipped: {exc}")
        yield str(exc)
        return
    yield cluster
    cluster.stop()


MakeFleet = Callable[..., Awaitable[Fleet]]


@pytest.fixture(params=["sqlite", pytest.param("postgres", marks=pytest.mark.postgres)])
async def db_url(
    request: pytest.FixtureRequest, tmp_path: Path, pg_cluster: PgCluster | str
) -> str:
    if request.param == "sqlite":
        return f"sqlite:///{tmp_path / 'fleet.db'}"
    if isinstance(pg_cluster, str):
        pytest.skip(f"no PostgreSQL server: {pg_cluster}")
    return await pg_cluster.create_database(f"fleet_{next(_names)}")


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
