"""robotctl takes --json after the command as well as before it."""

from __future__ import annotations

import asyncio
import json

import pytest
from daemon_harness import running_daemon

from robotd import ctl


async def _robotctl(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str]:
    capsys.readouterr()
    code = await asyncio.to_thread(ctl.main, list(argv))
    return code, capsys.readouterr().out


class TestJsonAfterTheCommand:
    async def test_status_json_after_the_command_is_json(
            self, capsys: pytest.CaptureFixture[str]) -> None:
        """``robotctl status --json`` prints the same JSON object as ``robotctl --json
        status``; without --json it is the table."""
        async with running_daemon(config={"robot": {"name": "json-1"}}) as daemon:
            sock = str(daemon.socket_path)
            after = await _robotctl(capsys, "--socket", sock, "status", "--json")
            before = await _robotctl(capsys, "--socket", sock, "--json", "status")
            table = await _robotctl(capsys, "--socket", sock, "status")
            tune = await _robotctl(capsys, "--socket", sock, "tune", "get", "line_follow.kp",
                                   "--json")
        assert after[0] == before[0] == 0
        assert json.loads(after[1])["robot"] == json.loads(before[1])["robot"] == "json-1"
        assert table[1].startswith("KEY")
        assert json.loads(tune[1])["key"] == "line_follow.kp"

    def test_json_is_off_unless_given_somewhere(self) -> None:
        parser = ctl.build_parser()
        assert parser.parse_args(["events", "--limit", "3"]).json is False
        assert parser.parse_args(["events", "--json", "--limit", "3"]).json is True
        assert parser.parse_args(["--json", "events"]).json is True
