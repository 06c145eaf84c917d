"""``robotd-fleet token create|list|revoke``: the token printed once, never listed, revoked
for good."""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Iterator
from pathlib import Path

import pytest
import structlog
from fleet_harness import SITE_TOML

from fleet.cli import main
from fleet.db import Database
from fleet.server import FleetServer
from fleet.site import parse_site
from fleet.tokens import find, token_hash


@pytest.fixture(autouse=True)
def _logging_restored() -> Iterator[None]:
    """main() sets up the process's logging; later tests get theirs back."""
    config = structlog.get_config()
    root = logging.getLogger()
    handlers, level = root.handlers[:], root.level
    yield
    structlog.configure(**config)
    root.handlers[:] = handlers
    root.setLevel(level)


def _site_db(tmp_path: Path) -> str:
    url = f"sqlite:///{tmp_path / 'fleet.db'}"

    async def seed() -> None:
        server = FleetServer(url, site=parse_site(SITE_TOML, "test-site"))
        await server.start(monitors=False)
        await server.stop()

    asyncio.run(seed())
    return url


def _quiet_db(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> str:
    url = _site_db(tmp_path)
    capsys.readouterr()  # the seeding's log lines
    return url


def _principal(url: str, token: str) -> object:
    async def look() -> object:
        db = Database(url)
        try:
            async with db.read() as session:
                return await find(session, token_hash(token))
        finally:
            await db.dispose()

    return asyncio.run(look())


class TestTokenCommands:
    def test_create_list_revoke(self, tmp_path: Path, capsys: pytest.CaptureFixture[str]):
        """create prints a new token once; list shows id, role and subject but no token;
        revoke makes the token useless."""
        url = _quiet_db(tmp_path, capsys)
        assert main(["token", "create", "--robot", "robot-1", "--db", url]) == 0
        token = capsys.readouterr().out.strip()
        assert len(token) >= 43 and "\n" not in token
        assert _principal(url, token) is not None

        assert main(["token", "list", "--db", url]) == 0
        listed = capsys.readouterr().out
        assert "robot-1" in listed and "robot" in listed
        assert token not in listed
        token_id = max(int(line.split()[0]) for line in listed.splitlines()[1:]
                       if line.split()[1:3] == ["robot", "robot-1"])  # the newest

        assert main(["token", "revoke", str(token_id), "--db", url]) == 0
        assert "revoked" in capsys.readouterr().out
        assert _principal(url, token) is None

    def test_tokens_for_customers_and_admins(self, tmp_path: Path,
                                            capsys: pytest.CaptureFixture[str]):
        url = _quiet_db(tmp_path, capsys)
        assert main(["token", "create", "--customer", "3", "--db", url]) == 0
        assert main(["token", "create", "--admin", "night-shift", "--db", url]) == 0
        first, second = capsys.readouterr().out.split()
        assert first != second

    def test_an_unknown_robot_or_id_is_an_error(self, tmp_path: Path,
                                               capsys: pytest.CaptureFixture[str]):
        url = _quiet_db(tmp_path, capsys)
        assert main(["token", "create", "--robot", "robot-9", "--db", url]) == 1
        assert "robot 'robot-9' is not registered" in capsys.readouterr().err
        assert main(["token", "revoke", "999", "--db", url]) == 1
        assert "token 999 does not exist" in capsys.readouterr().err
