"""``robotd update SOURCE`` and ``robotd update --rollback``: a new version beside the current
one, switched to only when its own check-config takes the robot's config and the robot is
idle or docked, and switched back by itself when the service does not come up ready.

Steps of an update: ask the running daemon (control socket, ``status``) that the robot is
idle or docked (no daemon: idle); install ``/opt/robotd/versions/<id>``; run the NEW
version's ``check-config`` on ``/etc/robotd/robotd.toml`` (refused: the new version is
removed, ``current`` unchanged); ask again; point ``current`` at it (``previous`` at the old
one); restart the service if it was running and wait for ``status`` to answer ``ready``; if
it does not within ``--ready-timeout``, point ``current`` back and restart again.
"""

from __future__ import annotations

import argparse
import os
import socket
import subprocess
import sys
import time
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from robotd.ctl.connection import CannotConnect, Connection, DaemonError
from robotd.install import versions
from robotd.install.layout import UNIT, Layout
from robotd.install.system import InstallError, System, system_for

HELP = "install a new version beside the current one and switch to it (or --rollback)"
DEFAULT_SOCKET = "/run/robotd/control.sock"
# A robot may change versions only while it does nothing: in idle, or on its dock.
SAFE_STATES = ("idle", "docking.charging", "docking.emptying", "docking.standby")
POLL_S = 0.25


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("source", nargs="?", type=Path, metavar="SOURCE",
                        help="a robotd checkout (directory) or wheel")
    parser.add_argument("--rollback", action="store_true",
                        help="go back to the previous version (a second --rollback returns)")
    parser.add_argument("--root", type=Path, default=Path("/"),
                        help="the installation under this directory (no systemctl runs: the "
                        "restart is written to DIR/opt/robotd/root-commands.log)")
    parser.add_argument("--config", type=Path, help="the config the new version must accept "
                        "(default /etc/robotd/robotd.toml under the root)")
    parser.add_argument("--socket", help="the running daemon's control socket (default: the "
                        "config's control.socket)")
    parser.add_argument("--ready-timeout", type=float, default=60.0, metavar="S",
                        help="how long the restarted service gets to answer ready before the "
                        "update is rolled back (default 60, the unit's TimeoutStartSec)")
    parser.add_argument("--deps-from", type=Path, metavar="VENV",
                        help="take the dependencies from this virtual environment instead of "
                        "installing them (no download)")
    parser.add_argument("--extras", default="", help="robotd's extras to install, e.g. pi")


class Refused(Exception):
    """The update or rollback is not done; the message says why, in one line."""


@dataclass
class DaemonStatus:
    """What the running daemon said (``running`` False: no daemon answered)."""

    running: bool
    state: str = ""
    robot: str = ""
    ready: bool = False
    pid: int | None = None


def ask_daemon(path: str, timeout_s: float = 5.0) -> DaemonStatus:
    """The daemon's ``status``; not running when there is no socket or nobody listens."""
    probe = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    try:
        probe.connect(path)
    except (FileNotFoundError, ConnectionRefusedError):
        return DaemonStatus(running=False)
    except OSError as exc:  # permission denied: robotd may well be running
        msg = (f"cannot ask robotd whether the robot is idle: {path}: {exc.strerror} "
               "(run as root or as a member of group robotd)")
        raise Refused(msg) from None
    finally:
        probe.close()
    try:
        connection = Connection(path, timeout_s)
        try:
            status: dict[str, Any] = connection.call("status")
        finally:
            connection.close()
    except (CannotConnect, DaemonError) as exc:
        msg = f"cannot ask robotd whether the robot is idle: {exc}"
        raise Refused(msg) from None
    return DaemonStatus(True, str(status.get("state", "")), str(status.get("robot", "")),
                  bool(status.get("ready")), status.get("pid"))


def is_safe(state: str) -> bool:
    return any(state == safe or state.startswith(f"{safe}.") for safe in SAFE_STATES)


@dataclass
class Updater:
    layout: Layout
    system: System
    config: Path
    socket_path: str
    ready_timeout_s: float
    say: Any = print

    def require_idle(self) -> DaemonStatus:
        daemon = ask_daemon(self.socket_path)
        if daemon.running and not is_safe(daemon.state):
            msg = (f"{daemon.robot or 'the robot'} is in {daemon.state}, not idle or docked: "
                   "update it when it is idle or on its dock (robotctl status)")
            raise Refused(msg)
        return daemon

    def check_config(self, version: str) -> None:
        robotd = versions.robotd_of(self.layout, version)
        proc = subprocess.run([str(robotd), "check-config", str(self.config)],
                              capture_output=True, text=True, check=False,
                              env=versions.version_env())
        if proc.returncode != 0:
            for line in (proc.stdout + proc.stderr).splitlines():
                self.say(f"  {line}")
            msg = f"robotd {version} does not accept {self.config} (above)"
            raise Refused(msg)

    def update(self, source_path: Path, deps_from: Path | None,
               extras: tuple[str, ...]) -> str:
        current = self._current()
        source = versions.read_source(source_path)
        if source.id == current:
            self.say(f"robotd {current} is the current version already: nothing to do")
            return current
        self.require_idle()
        existed = versions.is_complete(self.layout, source.id)
        if not existed:
            self.say(f"installing robotd {source.id} beside {current}")
            versions.install_version(self.layout, source, deps_from=deps_from, extras=extras)
        try:
            self.check_config(source.id)
            before = self.require_idle()
        except Refused:
            if not existed:
                versions.remove_version(self.layout, source.id)
            raise
        self._switch(source.id, current, before, roll_back=True)
        return source.id

    def rollback(self) -> str:
        current = self._current()
        previous = self.layout.previous_version()
        if previous is None or not versions.is_complete(self.layout, previous):
            msg = f"no previous version to roll back to ({self.layout.previous} is not there)"
            raise Refused(msg)
        self.check_config(previous)
        before = self.require_idle()
        self._switch(previous, current, before, roll_back=False)
        return previous

    def _current(self) -> str:
        current = self.layout.current_version()
        if current is None:
            msg = (f"no robotd installed under {self.layout.opt} (no current version): "
                   "scripts/install-robot first")
            raise Refused(msg)
        return current

    def _switch(self, new: str, old: str, before: DaemonStatus, *, roll_back: bool) -> None:
        versions.switch_current(self.layout, new)
        self.say(f"current -> versions/{new} (previous: {old})")
        if not before.running and self.layout.is_real:
            self.say("robotd is not running: not started (systemctl start robotd)")
            return
        self.system.run(["systemctl", "restart", UNIT])
        if not before.running:  # --root with no daemon to ask: the restart is recorded
            return
        if self._wait_ready(before):
            self.say(f"robotd {new} is ready")
            return
        if not roll_back:
            msg = (f"robotd {new} did not answer ready within {self.ready_timeout_s:g} s "
                   "(journalctl -u robotd)")
            raise Refused(msg)
        versions.switch_current(self.layout, old)
        self.system.run(["systemctl", "restart", UNIT])
        msg = (f"robotd {new} did not answer ready within {self.ready_timeout_s:g} s: rolled "
               f"back to {old} (journalctl -u robotd shows why)")
        raise Refused(msg)

    def _wait_ready(self, before: DaemonStatus) -> bool:
        """True once a daemon answers ready — a new process, on a real system."""
        deadline = time.monotonic() + self.ready_timeout_s
        while time.monotonic() < deadline:
            try:
                now = ask_daemon(self.socket_path, timeout_s=min(5.0, self.ready_timeout_s))
            except Refused:
                now = DaemonStatus(running=False)
            restarted = not self.layout.is_real or now.pid != before.pid
            if now.running and now.ready and restarted:
                return True
            time.sleep(POLL_S)
        return False


def control_socket(layout: Layout, config: Path, given: str | None) -> str:
    """--socket, else the config's control.socket (under the root), else the default."""
    if given:
        return given
    configured = DEFAULT_SOCKET
    try:
        section = tomllib.loads(config.read_text()).get("control", {})
        if isinstance(section, dict) and isinstance(section.get("socket"), str):
            configured = section["socket"]
    except (OSError, tomllib.TOMLDecodeError, UnicodeDecodeError):
        pass  # check-config names what is wrong with it
    return configured if layout.is_real else str(layout.at(configured))


def run(args: argparse.Namespace) -> int:
    """``robotd update``: 0 done (or nothing to do), 1 refused or failed, 2 usage."""
    if args.rollback == (args.source is not None):
        print("robotd update: give SOURCE (a checkout or a wheel) or --rollback",
              file=sys.stderr)
        return 2
    layout = Layout(args.root)
    if layout.is_real and os.geteuid() != 0:
        print("robotd update: run as root (sudo robotd update ...)", file=sys.stderr)
        return 2
    config = args.config or layout.config
    updater = Updater(layout, system_for(layout), config,
                      control_socket(layout, config, args.socket), args.ready_timeout)
    try:
        if args.rollback:
            version = updater.rollback()
            print(f"robotd update: rolled back to {version}")
        else:
            extras = tuple(e for e in args.extras.split(",") if e)
            version = updater.update(args.source, args.deps_from, extras)
            print(f"robotd update: running {version}")
    except (Refused, InstallError) as exc:
        print(f"robotd update: refused: {exc}" if isinstance(exc, Refused)
              else f"robotd update: {exc}", file=sys.stderr)
        return 1
    return 0
