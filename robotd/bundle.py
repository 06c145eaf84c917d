"""``robotd bundle``: one tar.gz a technician can send, with what it takes to see what a robot
did and ran, and no secret.

It holds the versions (robotd, Python, OS, the installed packages), the config and tuning
overrides with every secret removed, the state store (mission records, the e-stop latch) and
the transitions the daemon remembers, ``status`` (services, restarts), ``sensors`` (every
driver's counters), the events of the last ``--minutes`` and the latest MCAP recording. A
value under a key that ends in ``token``, ``password`` or ``secret`` (and the like) is
replaced by ``<removed>``, the fleet token file is never read into it, and as a last guard
the token's text and every removed value are searched for and blanked in every member.
"""

from __future__ import annotations

import argparse
import io
import json
import os
import platform
import re
import sqlite3
import sys
import tarfile
import tempfile
import time
import tomllib
from dataclasses import dataclass, field
from datetime import UTC, datetime
from importlib import metadata
from pathlib import Path
from typing import Any

from robotd import __version__
from robotd.config.overrides import render_toml
from robotd.ctl.connection import CannotConnect, Connection, DaemonError

HELP = "write one archive for a technician: versions, config without secrets, state, events"
DEFAULT_CONFIG = "/etc/robotd/robotd.toml"
DEFAULT_SOCKET = "/run/robotd/control.sock"
REMOVED = "<removed>"
SECRET_SUFFIXES = ("token", "password", "passwd", "secret", "api_key", "apikey",
                   "private_key", "credentials")
_URL_PASSWORD = re.compile(r"(?P<head>[a-z][a-z0-9+.-]*://[^/:@\s]*:)(?P<pw>[^@/\s]+)@", re.I)
# A token shorter than this is not searched for in the text (it would blank common words).
MIN_SECRET_CHARS = 6
EVENT_LIMIT = 1000


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--socket", help="the daemon's control socket (default $ROBOTD_SOCKET, "
                        "the config's control.socket, or /run/robotd/control.sock)")
    parser.add_argument("--out", type=Path, help="the archive to write (default "
                        "robotd-bundle-ROBOT-TIME.tar.gz here)")
    parser.add_argument("--minutes", type=float, default=30.0,
                        help="events of the last N minutes (default 30)")
    parser.add_argument("--config", type=Path, help="the config file (default: the one the "
                        f"daemon runs on, $ROBOTD_CONFIG or {DEFAULT_CONFIG})")
    parser.add_argument("--recording", type=Path, metavar="MCAP",
                        help="a recording to include instead of the newest [viz] record file "
                        "(e.g. robotd sim --report DIR's DIR/run.mcap)")


def is_secret_key(key: str) -> bool:
    return key.lower().replace("-", "_").endswith(SECRET_SUFFIXES)


@dataclass
class Redactor:
    """Removes secrets from values, and remembers each removed text to blank it everywhere."""

    secrets: set[str] = field(default_factory=set)

    def remember(self, text: str) -> None:
        text = text.strip()
        if len(text) >= MIN_SECRET_CHARS:
            self.secrets.add(text)

    def value(self, value: Any) -> Any:
        if isinstance(value, dict):
            out = {}
            for key, item in value.items():
                if is_secret_key(str(key)):
                    self._remember_all(item)
                    out[key] = REMOVED
                else:
                    out[key] = self.value(item)
            return out
        if isinstance(value, list):
            return [self.value(item) for item in value]
        if isinstance(value, str):
            for match in _URL_PASSWORD.finditer(value):
                self.remember(match["pw"])
            return _URL_PASSWORD.sub(rf"\g<head>{REMOVED}@", value)
        return value

    def _remember_all(self, value: Any) -> None:
        if isinstance(value, dict):
            for item in value.values():
                self._remember_all(item)
        elif isinstance(value, list):
            for item in value:
                self._remember_all(item)
        elif isinstance(value, str | int | float) and not isinstance(value, bool):
            self.remember(str(value))

    def text(self, text: str) -> str:
        for secret in sorted(self.secrets, key=len, reverse=True):
            text = text.replace(secret, REMOVED)
        return text


@dataclass
class Bundle:
    """The archive's members (name -> text or bytes), and what could not be collected."""

    redactor: Redactor = field(default_factory=Redactor)
    members: dict[str, str | bytes] = field(default_factory=dict)
    missing: list[str] = field(default_factory=list)

    def add_json(self, name: str, value: Any) -> None:
        self.members[name] = json.dumps(self.redactor.value(value), indent=2, default=str) + "\n"

    def _bytes(self, content: str | bytes) -> bytes:
        """Text goes through the last guard (every secret met is blanked); a recording's
        bytes are kept as they are."""
        return self.redactor.text(content).encode() if isinstance(content, str) else content

    def write(self, out: Path, prefix: str) -> None:
        """The tar.gz, readable by its owner only (it holds the robot's config)."""
        fd = os.open(out, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        now = time.time()
        with os.fdopen(fd, "wb") as raw, tarfile.open(fileobj=raw, mode="w:gz") as tar:
            for name, content in sorted(self.members.items()):
                data = self._bytes(content)
                info = tarfile.TarInfo(f"{prefix}/{name}")
                info.size, info.mode, info.mtime = len(data), 0o644, int(now)
                tar.addfile(info, io.BytesIO(data))


def collect(bundle: Bundle, socket_path: str, config_arg: Path | None, minutes: float,
            recording: Path | None = None) -> str:
    """Fill ``bundle``; returns the robot's name (for the archive's name)."""
    daemon = _ask(socket_path, bundle)
    status = daemon.get("status") or {}
    config_path = _config_path(config_arg, status)
    values = _read_config(bundle, config_path)
    _fleet_token(bundle, values)
    bundle.add_json("versions.json", _versions(status))
    state_dir = Path(os.environ.get("STATE_DIRECTORY", "").split(":")[0]
                     or _get(values, "robot", "state_dir") or "/var/lib/robotd")
    _state(bundle, state_dir)
    if daemon:
        bundle.add_json("status.json", status)
        bundle.add_json("sensors.json", daemon.get("sensors"))
        events = list(daemon.get("events") or [])
        transitions = [e for e in events if e.get("kind") == "transition"]
        bundle.add_json("state/transitions.json", transitions)
        recent, how = _recent(events, float(status.get("uptime_s") or 0), minutes)
        bundle.members["events.jsonl"] = "".join(
            json.dumps(bundle.redactor.value(e), default=str) + "\n" for e in recent)
        bundle.add_json("events-window.json", {"minutes": minutes, "counted_from": how,
                                               "events": len(recent)})
    _recording(bundle, values, state_dir, recording)
    name = str(status.get("robot") or _get(values, "robot", "name") or "robot")
    return re.sub(r"[^A-Za-z0-9_.-]", "_", name)


def _ask(socket_path: str, bundle: Bundle) -> dict[str, Any]:
    try:
        connection = Connection(socket_path, 5.0)
    except CannotConnect as exc:
        bundle.missing.append(f"status, sensors, events: {exc}")
        return {}
    try:
        return {"status": connection.call("status"), "sensors": connection.call("sensors"),
                "events": connection.call("events", {"limit": EVENT_LIMIT})}
    except (CannotConnect, DaemonError) as exc:
        bundle.missing.append(f"status, sensors, events: {exc}")
        return {}
    finally:
        connection.close()


def _config_path(given: Path | None, status: dict[str, Any]) -> Path:
    if given is not None:
        return given
    running = status.get("config")
    if isinstance(running, str) and Path(running).is_file():
        return Path(running)
    return Path(os.environ.get("ROBOTD_CONFIG") or DEFAULT_CONFIG)


def _read_config(bundle: Bundle, path: Path) -> dict[str, Any]:
    """config.toml: the values with secrets removed (the file's comments are not kept: a
    secret may sit in one)."""
    try:
        values = tomllib.loads(path.read_text())
    except OSError as exc:
        bundle.missing.append(f"config: {path}: {exc.strerror}")
        return {}
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        bundle.missing.append(f"config: {path}: not readable as TOML ({exc}); not included")
        return {}
    _add_toml(bundle, "config.toml", values, f"{path}, secrets removed")
    return values


def _add_toml(bundle: Bundle, name: str, values: dict[str, Any], what: str) -> None:
    clean = bundle.redactor.value(values)
    try:
        bundle.members[name] = f"# {what}\n" + render_toml(clean)
    except (TypeError, ValueError):
        bundle.add_json(name.replace(".toml", ".json"), clean)


def _fleet_token(bundle: Bundle, values: dict[str, Any]) -> None:
    """The fleet token is never in the bundle: its text is only read to be blanked."""
    configured = str(_get(values, "fleet", "token_file") or "")
    credentials = os.environ.get("CREDENTIALS_DIRECTORY", "")
    candidates = [Path("/etc/robotd/fleet-token")]
    if configured:
        candidates.append(Path(configured))
        if credentials and not Path(configured).is_absolute():
            candidates.append(Path(credentials) / configured)
    elif credentials:
        candidates.append(Path(credentials) / "fleet-token")
    for path in candidates:
        try:
            bundle.redactor.remember(path.read_text(errors="replace"))
        except OSError:
            continue


def _versions(status: dict[str, Any]) -> dict[str, Any]:
    os_release = {}
    try:
        for line in Path("/etc/os-release").read_text().splitlines():
            key, _, value = line.partition("=")
            os_release[key] = value.strip('"')
    except OSError:
        pass
    try:
        model = Path("/proc/device-tree/model").read_text(errors="replace").rstrip("\0")
    except OSError:
        model = None
    installed = Path("/opt/robotd/versions")
    current = Path("/opt/robotd/current")
    return {
        "robotd": __version__,
        "robotd_running": status.get("version"),
        "robotd_pid": status.get("pid"),
        "python": sys.version,
        "python_executable": sys.executable,
        "os": os_release.get("PRETTY_NAME"),
        "platform": platform.platform(),
        "machine": platform.machine(),
        "board": model,
        "installed_versions": sorted(p.name for p in installed.iterdir())
        if installed.is_dir() else [],
        "current_version": current.readlink().name if current.is_symlink() else None,
        "packages": sorted({f"{d.metadata['Name']}=={d.version}"
                            for d in metadata.distributions() if d.metadata["Name"]},
                           key=str.lower),
    }


def _state(bundle: Bundle, state_dir: Path) -> None:
    store = state_dir / "state.sqlite3"
    if not store.exists():
        bundle.missing.append(f"state store: {store}: no such file")
    else:
        try:
            bundle.add_json("state/store.json", _read_store(store))
        except sqlite3.Error as exc:
            bundle.missing.append(f"state store: {store}: {exc}")
    overrides = state_dir / "overrides.toml"
    try:
        values = tomllib.loads(overrides.read_text())
    except FileNotFoundError:
        return
    except (OSError, tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        bundle.missing.append(f"tuning overrides: {overrides}: {exc}")
        return
    _add_toml(bundle, "state/overrides.toml", values, f"{overrides}, secrets removed")


def _read_store(path: Path) -> dict[str, Any]:
    """The store's keys and values, read from a copy (the daemon keeps writing the live one,
    and a reader without write access cannot open a WAL database in place)."""
    with tempfile.TemporaryDirectory(prefix="robotd-bundle-") as tmp:
        copy = Path(tmp) / path.name
        for suffix in ("", "-wal"):
            source = Path(f"{path}{suffix}")
            if source.exists():
                Path(f"{copy}{suffix}").write_bytes(source.read_bytes())
        db = sqlite3.connect(copy)
        try:
            rows = db.execute("SELECT key, value FROM kv ORDER BY key").fetchall()
        finally:
            db.close()
    out: dict[str, Any] = {}
    for key, text in rows:
        try:
            out[key] = json.loads(text)
        except json.JSONDecodeError:
            out[key] = {"unreadable": text[:200]}
    return out


def _recent(events: list[dict[str, Any]], uptime_s: float,
            minutes: float) -> tuple[list[dict[str, Any]], str]:
    """The events of the last ``minutes``. ``robotd run``'s event times are the event loop's
    clock, this machine's monotonic clock; the simulator's are its own (virtual) clock, so
    there the window is counted back from the newest event."""
    times = [float(e["t"]) for e in events if isinstance(e.get("t"), int | float)]
    if not times:
        return [], "no events"
    now = time.monotonic()
    if now - uptime_s - 1 <= min(times) and max(times) <= now + 1:
        cutoff, how = now - minutes * 60, "now (the daemon's clock is this machine's)"
    else:
        cutoff, how = max(times) - minutes * 60, "the newest event (a simulator's clock)"
    return [e for e in events if float(e.get("t", cutoff)) >= cutoff], how


def _recording(bundle: Bundle, values: dict[str, Any], state_dir: Path,
               given: Path | None) -> None:
    """The recording given, else the newest ``[viz] record`` file in the state directory."""
    if given is not None:
        try:
            bundle.members[f"recording/{given.name}"] = given.read_bytes()
        except OSError as exc:
            bundle.missing.append(f"recording: {given}: {exc.strerror}")
        return
    if not _get(values, "viz", "record"):
        bundle.missing.append("recording: [viz] record is off in the config")
        return
    files = sorted((state_dir / "viz").glob("*.mcap"), key=lambda p: p.stat().st_mtime)
    if not files:
        bundle.missing.append(f"recording: no *.mcap in {state_dir / 'viz'}")
        return
    bundle.members[f"recording/{files[-1].name}"] = files[-1].read_bytes()


def _get(values: dict[str, Any], section: str, key: str) -> Any:
    table = values.get(section)
    return table.get(key) if isinstance(table, dict) else None


def _socket_path(given: str | None, config: Path | None) -> str:
    if given:
        return given
    if os.environ.get("ROBOTD_SOCKET"):
        return os.environ["ROBOTD_SOCKET"]
    try:
        values = tomllib.loads((config or Path(DEFAULT_CONFIG)).read_text())
    except (OSError, tomllib.TOMLDecodeError, UnicodeDecodeError):
        return DEFAULT_SOCKET
    return str(_get(values, "control", "socket") or DEFAULT_SOCKET)


def run(args: argparse.Namespace) -> int:
    """``robotd bundle``: 0 written (what could not be collected is listed in MANIFEST.txt)."""
    if args.minutes <= 0:
        print(f"robotd bundle: --minutes: expected a number above 0, got {args.minutes:g}",
              file=sys.stderr)
        return 2
    bundle = Bundle()
    robot = collect(bundle, _socket_path(args.socket, args.config), args.config, args.minutes,
                    args.recording)
    stamp = datetime.now(UTC).strftime("%Y%m%dT%H%M%SZ")
    prefix = f"robotd-bundle-{robot}-{stamp}"
    out: Path = args.out or Path(f"{prefix}.tar.gz")
    bundle.members["MANIFEST.txt"] = _manifest(bundle, args.minutes)
    try:
        bundle.write(out, prefix)
    except OSError as exc:
        print(f"robotd bundle: cannot write {out}: {exc.strerror}", file=sys.stderr)
        return 1
    print(f"robotd bundle: {out} ({len(bundle.members)} files"
          + (f"; not included: {len(bundle.missing)}, see MANIFEST.txt" if bundle.missing
             else "") + ")")
    return 0


def _manifest(bundle: Bundle, minutes: float) -> str:
    lines = [f"robotd bundle, made {datetime.now(UTC).isoformat(timespec='seconds')} by "
             f"robotd {__version__}", "",
             "Secrets removed: values under keys ending in token, password, secret (and the "
             "like), passwords in URLs; the fleet token file is never included.", "",
             "Files:"]
    lines += [f"  {name}" for name in sorted(bundle.members)]
    lines += [f"  (events.jsonl: the last {minutes:g} minutes)", ""]
    if bundle.missing:
        lines += ["Not included:"] + [f"  {why}" for why in bundle.missing]
    return "\n".join(lines) + "\n"
