"""Schemathesis fuzzes every operation of the served OpenAPI document against a real
`robotd-fleet serve` process: no input makes the server answer 500."""

from __future__ import annotations

import asyncio
import os
import shutil
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest
import schemathesis
from hypothesis import HealthCheck, given, settings
from hypothesis.errors import Unsatisfiable
from pgtest import PgCluster
from schemathesis import GenerationMode
from schemathesis.checks import not_a_server_error

import fleet

SITE = Path(fleet.__file__).parent / "sites" / "example.toml"


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port: int = sock.getsockname()[1]
        return port


@pytest.fixture(scope="module",
                params=["sqlite", pytest.param("postgres", marks=pytest.mark.postgres)])
def served(
    request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory,
    pg_cluster: PgCluster | str,
) -> Iterator[str]:
    """A fleet server process on a fresh database with the example site."""
    db = tmp_path_factory.mktemp("fuzz") / "fleet.db"
    db_url = f"sqlite:///{db}"
    if request.param == "postgres":
        if isinstance(pg_cluster, str):
            pytest.skip(f"no PostgreSQL server: {pg_cluster}")
        db_url = asyncio.run(pg_cluster.create_database(f"fuzz_{os.getpid()}"))
    port = _free_port()
    exe = shutil.which("robotd-fleet", path=str(Path(sys.executable).parent)) or "robotd-fleet"
    log = (db.parent / "server.log").open("wb")
    proc = subprocess.Popen(
        [exe, "serve", "--db", db_url, "--site", str(SITE), "--port", str(port),
         "--log-level", "warning"], stdout=log, stderr=subprocess.STDOUT)
    url = f"http://127.0.0.1:{port}"
    try:
        for _ in range(300):
            if proc.poll() is not None:
                pytest.fail(f"robotd-fleet exited with {proc.returncode}")
            try:
                if httpx.get(f"{url}/health", timeout=1).status_code == 200:
                    break
            except httpx.TransportError:
                time.sleep(0.1)
        yield url
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        log.close()
        text = (db.parent / "server.log").read_text(errors="replace")
        assert "Traceback" not in text, text[-3000:]


def _operations(url: str) -> list[schemathesis.APIOperation]:
    api = schemathesis.openapi.from_url(f"{url}/openapi.json")
    return [result.ok() for result in api.get_all_operations()]


# schemathesis' pytest plugin (parametrize/from_fixture) does not run on pytest 9 yet, so each
# operation's hypothesis strategy is driven directly.
@pytest.mark.parametrize("mode", list(GenerationMode), ids=str)
def test_no_input_makes_the_server_fail(served: str, mode: GenerationMode) -> None:
    """Every generated call, valid (positive) or not (negative), of every operation gets an
    answer below 500."""
    operations = _operations(served)
    assert len(operations) >= 15

    for operation in operations:

        @given(case=operation.as_strategy(generation_mode=mode))
        @settings(max_examples=15, deadline=None, database=None,
                  suppress_health_check=list(HealthCheck))
        def call(case: schemathesis.Case) -> None:
            case.call_and_validate(base_url=served, checks=[not_a_server_error])

        try:
            call()
        except Unsatisfiable:
            # No invalid input exists for this operation (e.g. GET /health takes nothing).
            assert mode == GenerationMode.NEGATIVE, operation.label
