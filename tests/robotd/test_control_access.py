"""Who may use the control socket, and a daemon that cannot listen refuses to start."""

from __future__ import annotations

import asyncio
import grp
import os
import stat
import tempfile
from pathlib import Path

import pytest
from daemon_harness import RpcClient, running_daemon

from hal.backend import Devices
from hal.ports import system_wall_clock
from robotd.config import Settings
from robotd.config.loader import defaults
from robotd.control.access import make_runtime_dir, restrict, socket_problem
from robotd.daemon import Daemon
from robotd.profiles import PROFILES


def mode_of(path: Path | str) -> int:
    return stat.S_IMODE(os.stat(path).st_mode)


class TestAccess:
    def test_a_directory_the_daemon_creates_is_0750(self, tmp_path: Path) -> None:
        """Whatever the umask: only the owner writes, the group searches, others nothing."""
        old = os.umask(0)
        try:
            make_runtime_dir(tmp_path / "run" / "robotd")
        finally:
            os.umask(old)
        assert mode_of(tmp_path / "run" / "robotd") == 0o750

    def test_a_directory_that_exists_is_left_alone(self, tmp_path: Path) -> None:
        """systemd's RuntimeDirectory= made it with the unit's mode and group."""
        (tmp_path / "robotd").mkdir(mode=0o755)
        os.chmod(tmp_path / "robotd", 0o755)
        make_runtime_dir(tmp_path / "robotd")
        assert mode_of(tmp_path / "robotd") == 0o755

    def test_the_group_is_given_when_it_exists(self, tmp_path: Path) -> None:
        """The daemon's own primary group stands in for robotd (which needs root to make)."""
        target = tmp_path / "sock"
        target.write_text("")
        mine = grp.getgrgid(os.getegid()).gr_name
        restrict(target, 0o660, group=mine)
        assert mode_of(target) == 0o660 and os.stat(target).st_gid == os.getegid()

    def test_no_such_group_keeps_the_daemons_group_and_the_mode(self, tmp_path: Path) -> None:
        """A developer's machine with no robotd group: the mode holds, nothing raises."""
        target = tmp_path / "sock"
        target.write_text("")
        restrict(target, 0o660, group="no-such-group-robotd-test")
        assert mode_of(target) == 0o660 and os.stat(target).st_gid == os.getegid()

    async def test_the_running_daemons_socket_is_0660(self) -> None:
        async with running_daemon() as daemon:
            assert daemon.socket_path is not None
            assert mode_of(daemon.socket_path) == 0o660


class TestSocketProblem:
    def test_a_path_over_the_limit_another_daemon_or_a_file_are_named(self, tmp_path: Path
                                                                      ) -> None:
        assert "at most 107 bytes" in str(socket_problem("/" + "a" * 120))
        (tmp_path / "file").write_text("")
        assert "is not a socket" in str(socket_problem(str(tmp_path / "file")))
        assert socket_problem(str(tmp_path / "fine.sock")) is None

    async def test_another_daemon_listening_is_named(self) -> None:
        async with running_daemon() as daemon:
            assert daemon.socket_path is not None
            why = await asyncio.to_thread(socket_problem, daemon.socket_path)
        assert why is not None and "already listening" in why


class TestDaemonWithoutSocket:
    async def test_a_socket_it_cannot_bind_stops_the_start(self) -> None:
        """Given a path that cannot be bound (past sun_path), run() returns 1 with the problem
        naming control.socket, and READY is never said."""
        workdir = Path(tempfile.mkdtemp(prefix="rd-"))
        daemon = Daemon(Settings(defaults()), Devices(), PROFILES.build("idle"),
                        state_dir=workdir / "state", socket_path=str(workdir / ("s" * 120)),
                        wall_clock=system_wall_clock, notify=False, handle_signals=False)
        code = await asyncio.wait_for(daemon.run(), 20)
        assert code == 1 and not daemon.ready.is_set()
        assert any("control.socket" in p for p in daemon.start_problems), daemon.start_problems


class TestPersistOntoCorruptOverrides:
    @pytest.mark.parametrize("text", ["[line_follow\n", "x = " + "9" * 5000 + "\n"])
    async def test_is_applied_refused_to_persist_and_the_file_kept(self, text: str) -> None:
        """-32000 naming the file, not -32603; the live value is applied; the file untouched."""
        async with running_daemon() as daemon:
            assert daemon.socket_path is not None
            path = daemon.state_dir / "overrides.toml"
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text)
            client = await RpcClient.connect(daemon.socket_path)
            reply = await client.call("tune.set", {"key": "line_follow.kp", "value": 0.6,
                                                   "persist": True})
            await client.close()
            assert daemon.settings.get("line_follow.kp") == 0.6
            assert path.read_text() == text
        assert reply["error"]["code"] == -32000
        assert str(path) in reply["error"]["message"] and "fix or remove" in reply["error"][
            "message"]
