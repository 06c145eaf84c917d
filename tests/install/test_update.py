"""robotd update into a temporary root: a version the config check refuses is not switched
to, a robot mid-mission is not updated, a service that is not ready is rolled back, and
--rollback returns to the previous version."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path
from typing import Any

import pytest
from daemon_harness import running_daemon
from install_helpers import VENV, install_robot


@pytest.fixture
def installed(root: Path, wheels: tuple[Path, Path]) -> Path:
    """A root with robotd 0.1.0 installed (the idle profile: no devices) and current."""
    install_robot(root, "--profile", "idle", source=wheels[0])
    return root


def _current(root: Path) -> str:
    return str((root / "opt/robotd/current").readlink())


def _previous(root: Path) -> str:
    return str((root / "opt/robotd/previous").readlink())


def _commands(root: Path) -> list[str]:
    log = root / "opt/robotd/root-commands.log"
    return log.read_text().splitlines() if log.exists() else []


def _update_argv(root: Path, *args: str) -> list[str]:
    argv = [str(VENV / "bin" / "robotd"), "update", "--root", str(root), *args]
    return argv if "--rollback" in args else [*argv, "--deps-from", str(VENV)]


async def robotd_update(root: Path, *args: str) -> tuple[int, str, str]:
    """robotd update --root ROOT ARGS in a subprocess, leaving this event loop (and a daemon
    on it) running meanwhile."""
    proc = await asyncio.create_subprocess_exec(
        *_update_argv(root, *args), stdout=asyncio.subprocess.PIPE,
        stderr=asyncio.subprocess.PIPE)
    out, err = await asyncio.wait_for(proc.communicate(), 240)
    assert proc.returncode is not None
    return proc.returncode, out.decode(), err.decode()


class TestUpdate:
    async def test_a_version_whose_config_check_fails_is_refused(
            self, installed: Path, wheels: tuple[Path, Path]) -> None:
        """The NEW version's check-config refuses the robot's config: current stays, the new
        version is removed, nothing is restarted, and the problem is shown."""
        config = installed / "etc/robotd/robotd.toml"
        config.write_text(config.read_text().replace('[robot]\n', '[robot]\ncolour = "red"\n'))
        before = _current(installed)
        code, out, err = await robotd_update(installed, str(wheels[1]))
        assert code == 1
        assert "robot.colour: unknown key" in out
        [line] = err.splitlines()
        assert line.startswith("robotd update: refused: robotd 0.1.1.dev1-")
        assert line.endswith(f"does not accept {config} (above)")
        assert _current(installed) == before
        assert [p.name for p in (installed / "opt/robotd/versions").iterdir()] == [
            before.removeprefix("versions/")]
        assert "systemctl restart robotd.service" not in _commands(installed)

    async def test_update_then_rollback_returns_the_previous_current(
            self, installed: Path, wheels: tuple[Path, Path]) -> None:
        """Update: current is the new version, previous the old, the restart recorded.
        --rollback: current is the old one again (and previous the new one)."""
        old = _current(installed)
        code, out, err = await robotd_update(installed, str(wheels[1]))
        assert code == 0, err
        new = _current(installed)
        assert new.startswith("versions/0.1.1.dev1-") and _previous(installed) == old
        assert out.splitlines()[-1] == f"robotd update: running {new.removeprefix('versions/')}"
        assert _commands(installed)[-1] == "systemctl restart robotd.service"

        code, out, err = await robotd_update(installed, "--rollback")
        assert code == 0, err
        assert (_current(installed), _previous(installed)) == (old, new)
        assert [c for c in _commands(installed) if "restart" in c] == [
            "systemctl restart robotd.service"] * 2

    async def test_the_same_version_again_is_nothing_to_do(
            self, installed: Path, wheels: tuple[Path, Path]) -> None:
        before = _current(installed)
        code, out, _err = await robotd_update(installed, str(wheels[0]))
        assert code == 0 and "nothing to do" in out
        assert _current(installed) == before
        assert not (installed / "opt/robotd/previous").exists()

    async def test_rollback_with_no_previous_version_is_refused(self, installed: Path) -> None:
        code, _out, err = await robotd_update(installed, "--rollback")
        assert code == 1
        assert err.startswith("robotd update: refused: no previous version to roll back to")


class TestUpdateAsksTheDaemon:
    async def test_a_robot_mid_mission_is_not_updated(
            self, installed: Path, wheels: tuple[Path, Path]) -> None:
        """The running daemon says it is in a mission: refused before anything is
        installed, naming the robot and its state."""
        async with running_daemon() as daemon:
            assert await daemon.context.trigger("start_mission")
            state = daemon.state
            assert state.startswith("mission")
            before = _current(installed)
            code, _out, err = await robotd_update(
                installed, str(wheels[1]), "--socket", str(daemon.socket_path))
        assert code == 1
        assert err.strip() == (
            f"robotd update: refused: robot-1 is in {state}, not idle or docked: update it "
            "when it is idle or on its dock (robotctl status)")
        assert _current(installed) == before
        assert len(list((installed / "opt/robotd/versions").iterdir())) == 1

    async def test_an_idle_robot_is_updated_and_the_service_answers_ready(
            self, installed: Path, wheels: tuple[Path, Path]) -> None:
        async with running_daemon() as daemon:
            code, out, err = await robotd_update(
                installed, str(wheels[1]), "--socket", str(daemon.socket_path))
        assert code == 0, err
        assert _current(installed).startswith("versions/0.1.1.dev1-")
        assert "is ready" in out

    async def test_a_service_not_ready_in_time_is_rolled_back(
            self, installed: Path, wheels: tuple[Path, Path], tmp_path: Path) -> None:
        """After the restart the service never answers ready: current goes back to the old
        version and the service is restarted on it, and the command says so."""
        socket_path = str(tmp_path / "c.sock")
        async with _daemon_ready_only_before_the_restart(socket_path):
            old = _current(installed)
            code, _out, err = await robotd_update(
                installed, str(wheels[1]), "--socket", socket_path, "--ready-timeout", "1")
        assert code == 1
        assert "did not answer ready within 1 s: rolled back to " in err
        assert _current(installed) == old
        assert [c for c in _commands(installed) if "restart" in c] == [
            "systemctl restart robotd.service"] * 2


def _status(ready: bool) -> dict[str, Any]:
    return {"robot": "robot-1", "state": "idle" if ready else "boot", "ready": ready, "pid": 1}


class _daemon_ready_only_before_the_restart:  # noqa: N801 - used as a context manager
    """A control socket that answers ``status`` as an idle, ready daemon twice (the update's
    two idle checks) and then as one that never gets ready (a version that hangs at start)."""

    def __init__(self, path: str) -> None:
        self.path = path
        self.calls = 0
        self.server: asyncio.Server | None = None

    async def _serve(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        while line := await reader.readline():
            request = json.loads(line)
            self.calls += 1
            reply = {"jsonrpc": "2.0", "id": request["id"], "result": _status(self.calls <= 2)}
            writer.write(json.dumps(reply).encode() + b"\n")
            await writer.drain()
        writer.close()

    async def __aenter__(self) -> None:
        self.server = await asyncio.start_unix_server(self._serve, self.path)

    async def __aexit__(self, *_exc: object) -> None:
        assert self.server is not None
        self.server.close()
        await self.server.wait_closed()
