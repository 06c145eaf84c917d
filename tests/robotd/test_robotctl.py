"""robotctl against a running daemon: tables, --json, exit codes, clear connect errors."""

from __future__ import annotations

import asyncio
import json
import os
import re
import shutil
import socket
import subprocess
import sys
import tempfile
import threading
from pathlib import Path

import pytest
from daemon_harness import running_daemon

from robotd import ctl
from robotd.ctl import watch as ctl_watch

LOG_LINE = re.compile(r"^\d{4}-\d\d-\d\d \d\d:\d\d:\d\d \[")


async def robotctl(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    """Run robotctl in a thread (it blocks; the daemon must not); its output without logs."""
    capsys.readouterr()
    code = await asyncio.to_thread(ctl.main, list(argv))
    out = capsys.readouterr()

    def keep(text: str) -> str:
        return "".join(x for x in text.splitlines(keepends=True) if not LOG_LINE.match(x))

    return code, keep(out.out), keep(out.err)


class TestCommands:
    async def test_status_is_a_readable_table_by_default_and_json_on_request(
            self, capsys: pytest.CaptureFixture[str]) -> None:
        async with running_daemon(config={"robot": {"name": "tbl-1"}}) as daemon:
            sock = str(daemon.socket_path)
            code, table, _ = await robotctl(capsys, "--socket", sock, "status")
            jcode, text, _ = await robotctl(capsys, "--socket", sock, "--json", "status")
        assert code == jcode == 0
        assert "robot     tbl-1" in table
        assert "state     idle" in table
        assert "SERVICE" in table and "machine" in table
        assert json.loads(text)["robot"] == "tbl-1"

    async def test_tune_set_and_get(self, capsys: pytest.CaptureFixture[str]) -> None:
        async with running_daemon() as daemon:
            sock = str(daemon.socket_path)
            set_code, set_out, _ = await robotctl(capsys, "--socket", sock, "tune", "set",
                                                  "line_follow.kp", "0.6", "--persist")
            get_code, get_out, _ = await robotctl(capsys, "--socket", sock, "tune", "get",
                                                  "line_follow.kp")
            where = daemon.state_dir / "overrides.toml"
        assert (set_code, set_out) == (0, f"line_follow.kp = 0.6 (persisted in {where})\n")
        assert (get_code, get_out) == (0, "line_follow.kp = 0.6\n")

    async def test_a_refusal_is_exit_1_with_the_daemons_reason(
            self, capsys: pytest.CaptureFixture[str]) -> None:
        async with running_daemon() as daemon:
            code, _, err = await robotctl(capsys, "--socket", str(daemon.socket_path),
                                          "tune", "set", "line_follow.kp", "-3")
        assert code == 1
        assert err == "robotctl: robotd refused: line_follow.kp: must be >= 0, got -3\n"

    async def test_estop_resume_and_events(self, capsys: pytest.CaptureFixture[str]) -> None:
        async with running_daemon() as daemon:
            sock = str(daemon.socket_path)
            assert (await robotctl(capsys, "--socket", sock, "estop"))[0] == 0
            assert daemon.state == "estop"
            assert (await robotctl(capsys, "--socket", sock, "resume"))[0] == 0
            code, out, _ = await robotctl(capsys, "--socket", sock, "events", "--kind",
                                          "transition")
        assert code == 0
        assert "src=estop dst=idle trigger=resume" in out

    def test_usage_errors_exit_2(self, capsys: pytest.CaptureFixture[str]) -> None:
        with pytest.raises(SystemExit) as exc:
            ctl.main(["tune", "set", "line_follow.kp"])
        assert exc.value.code == 2


class TestConnectErrors:
    def test_a_missing_socket_says_so_and_exits_3(self, tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
        code = ctl.main(["--socket", str(tmp_path / "none.sock"), "status"])
        err = capsys.readouterr().err
        assert code == 3
        assert err.startswith(f"robotctl: no control socket at {tmp_path / 'none.sock'}: "
                              "is robotd running?")

    def test_a_stale_socket_nobody_listens_on_exits_3(self, tmp_path: Path,
                                                     capsys: pytest.CaptureFixture[str]) -> None:
        path = str(tmp_path / "stale.sock")
        with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as stale:
            stale.bind(path)
        assert ctl.main(["--socket", path, "status"]) == 3
        assert "nothing listens on" in capsys.readouterr().err

    def test_a_regular_file_is_not_called_a_stale_socket(
            self, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
        """--socket naming a regular file: said as such (it was "a stale socket")."""
        path = tmp_path / "robotd.toml"
        path.write_text("[robot]\n")
        assert ctl.main(["--socket", str(path), "status"]) == 3
        assert f"robotctl: {path} is not a socket" in capsys.readouterr().err

    def test_a_socket_without_permission_says_what_to_check(self) -> None:
        """robotctl run as a user outside the socket's group (root drops to nobody)."""
        prefix: list[str] = []
        if os.geteuid() == 0:
            if shutil.which("setpriv") is None:
                pytest.skip("needs setpriv to run robotctl as another user")
            prefix = ["setpriv", "--reuid=65534", "--regid=65534", "--clear-groups"]
        with (tempfile.TemporaryDirectory(prefix="rd-") as name,
              socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as server):
            Path(name).chmod(0o755)  # the directory is open; only the socket is 0660
            path = Path(name) / "locked.sock"
            server.bind(str(path))
            server.listen()
            path.chmod(0o660)
            done = subprocess.run([*prefix, sys.executable, "-m", "robotd.ctl", "--socket",
                                   str(path), "status"], capture_output=True, text=True,
                                  timeout=60, check=False)
        assert done.returncode == 3
        assert done.stderr.startswith(f"robotctl: permission denied on {path}: ")


class _Screen:
    """A terminal stand-in: keeps what was written; ends the watch once ``until`` shows."""

    def __init__(self, until: str = "", tty: bool = True) -> None:
        self.text = ""
        self.until = until
        self.tty = tty
        self.drawn = threading.Event()

    def isatty(self) -> bool:
        return self.tty

    def write(self, text: str) -> None:
        self.text += text

    def flush(self) -> None:
        self.drawn.set()
        if self.until and self.until in self.text.rsplit("\x1b[2J", 1)[-1]:
            raise KeyboardInterrupt


class TestWatch:
    def test_watch_redraws_in_place_on_a_terminal(self) -> None:
        """Each refresh starts with cursor-home + clear-screen when stdout is a TTY."""

        class Conn:
            path = "x"

            def call(self, method: str, params: object = None) -> object:
                return {"subscribe": {}, "status": {"robot": "w", "state": "idle",
                                                    "services": []},
                        "events": [{"kind": "transition", "t": 0.1, "src": "boot",
                                    "dst": "idle", "trigger": "booted"}],
                        "sensors": {"devices": {}}}[method]

            def next_notification(self, timeout_s: float) -> None:
                return None

        out = _Screen(until="state idle")
        assert ctl_watch.watch(Conn(), 1.0, out) == 0  # type: ignore[arg-type]
        assert out.text.startswith("\x1b[H\x1b[2J")
        assert "boot -> idle  (booted)" in out.text  # the transitions before it started

    def test_the_screen_fits_80_by_24_with_state_estop_and_link_on_top(self) -> None:
        """However many services and figures, the screen is 24 lines of at most 80 columns,
        and the first three say state, estop and link (the top scrolled away before)."""
        screen = ctl_watch.WatchScreen()
        screen.status = {"robot": "laundry-1", "profile": "laundry", "state": "mission.to_room",
                         "estop": False, "link": "connected", "uptime_s": 12.0,
                         "services": [{"name": f"service.number{i}", "state": "running",
                                       "restarts": i % 3} for i in range(30)]}
        screen.sensors = {"devices": {f"device{i}": {f"figure{j}": j * 1.5 for j in range(40)}
                                      for i in range(30)}}
        for i in range(10):
            screen.note({"method": "state", "params": {"t": i, "src": "a", "dst": f"b{i}",
                                                       "trigger": "go"}})
        lines = screen.lines(80, 23)
        assert len(lines) <= 23 and all(len(line) <= 80 for line in lines)
        assert "state mission.to_room" in lines[0]
        assert lines[1] == "estop no"
        assert lines[2].startswith("link connected")
        assert any("-> b9" in line for line in lines)

    async def test_a_transition_is_on_screen_as_soon_as_it_is_notified(self) -> None:
        """The watch subscribes to notifications: an estop shows without waiting for the
        (here: one minute) refresh interval."""
        async with running_daemon() as daemon:
            conn = ctl.Connection(str(daemon.socket_path), 5.0)
            out = _Screen(until="-> estop")
            watching = asyncio.create_task(asyncio.to_thread(ctl_watch.watch, conn, 60.0, out))
            assert await asyncio.to_thread(out.drawn.wait, 10)
            code = await asyncio.to_thread(ctl.main, ["--socket", str(daemon.socket_path),
                                                      "estop"])
            assert code == 0
            assert await asyncio.wait_for(watching, 10) == 0
            conn.close()
        assert "estop YES" in out.text.rsplit("\x1b[2J", 1)[-1]

    async def test_the_daemon_going_away_ends_the_watch_with_exit_3(self) -> None:
        """No ``Broken pipe`` traceback: it says robotd went away, exit 3."""
        async with running_daemon() as daemon:
            conn = ctl.Connection(str(daemon.socket_path), 5.0)
            out = _Screen()
            watching = asyncio.create_task(asyncio.to_thread(ctl_watch.watch, conn, 0.2, out))
            assert await asyncio.to_thread(out.drawn.wait, 10)
        assert await asyncio.wait_for(watching, 10) == 3
        assert "robotd went away" in out.text
