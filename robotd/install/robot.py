"""install-robot's steps: the service's accounts, a version, the config, udev rules, the unit.

Every step looks before it acts, so a second run changes nothing (not even a file's time).
What the install made that was not there (groups, the user, memberships, directories) is
written to ``/opt/robotd/install.json``; ``uninstall`` removes exactly that and the files it
installed, and keeps ``/etc/robotd`` (the config, the fleet token) unless ``purge``.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from robotd.install import versions
from robotd.install.layout import (
    COMMANDS,
    GROUP,
    HOME,
    NOLOGIN,
    SUPPLEMENTARY_GROUPS,
    UNIT,
    USER,
    Layout,
)
from robotd.install.system import InstallError, System, is_root

UDEV_RULES = Path("packaging") / "udev" / "99-robotd.rules"
UNIT_FILE = Path("systemd") / UNIT


@dataclass
class Manifest:
    """What this install made; kept in /opt/robotd/install.json."""

    groups: list[str] = field(default_factory=list)
    user: bool = False
    memberships: list[str] = field(default_factory=list)
    dirs: list[str] = field(default_factory=list)

    @classmethod
    def load(cls, path: Path) -> Manifest:
        if not path.exists():
            return cls()
        try:
            data: dict[str, Any] = json.loads(path.read_text())
            return cls(list(data["groups"]), bool(data["user"]), list(data["memberships"]),
                       list(data["dirs"]))
        except (ValueError, KeyError, TypeError) as exc:
            msg = f"{path}: cannot be read ({exc}): remove it to uninstall by hand"
            raise InstallError(msg) from None

    def text(self) -> str:
        return json.dumps({"groups": self.groups, "user": self.user,
                           "memberships": self.memberships, "dirs": self.dirs}, indent=2) + "\n"


@dataclass
class Installer:
    """One run of install-robot (or its --uninstall) under ``layout.root``."""

    layout: Layout
    system: System
    checkout: Path
    say: Any = print
    manifest: Manifest = field(default_factory=Manifest)

    # -- install -------------------------------------------------------------------------
    def install(self, source: Path, *, profile: str | None, deps_from: Path | None,
                extras: tuple[str, ...]) -> str:
        """Install everything; returns the current version's id."""
        self.manifest = Manifest.load(self.layout.manifest)
        self._mkdirs(self.layout.opt)
        # The manifest is saved after each step, so a run cut short (a package index out
        # of reach, a full disk) can still be uninstalled, or simply run again.
        self._accounts()
        self._save()
        version = self._version(source, deps_from, extras)
        self._save()
        self._config(version, profile)
        self._udev()
        self._unit()
        for name in COMMANDS:
            self._symlink(self.layout.command_link(name), f"/opt/robotd/current/bin/{name}")
        self._save()
        return version

    def _save(self) -> None:
        self._write(self.layout.manifest, self.manifest.text(), 0o644)

    def _accounts(self) -> None:
        s, m = self.system, self.manifest
        for group in (GROUP, *SUPPLEMENTARY_GROUPS):
            if not s.group_exists(group):
                s.add_group(group)
                m.groups.append(group)
                self.say(f"group {group}: made")
        if not s.user_exists(USER):
            s.add_user(USER, GROUP, HOME, NOLOGIN)
            m.user = True
            self.say(f"user {USER}: made (group {GROUP}, home {HOME})")
        have = s.groups_of(USER)
        for group in SUPPLEMENTARY_GROUPS:
            if group not in have:
                s.add_member(USER, group)
                if not m.user:  # a user we made goes whole; only a kept user's are listed
                    m.memberships.append(group)

    def _version(self, source_path: Path, deps_from: Path | None,
                 extras: tuple[str, ...]) -> str:
        source = versions.read_source(source_path)
        current = self.layout.current_version()
        if current is not None and current != source.id:
            self.say(f"robotd {current} is installed (current); {source.id} is not installed"
                     f" by install-robot: to move to it, robotd update {source_path}")
            return current
        if not versions.is_complete(self.layout, source.id):
            self._mkdirs(self.layout.versions)
            self.say(f"installing robotd {source.id} into {self.layout.version_dir(source.id)}")
            versions.install_version(self.layout, source, deps_from=deps_from, extras=extras)
        if current is None:
            versions.switch_current(self.layout, source.id)
            self.say(f"current -> versions/{source.id}")
        return source.id

    def _config(self, version: str, profile: str | None) -> None:
        layout = self.layout
        self._mkdirs(layout.etc, mode=0o750)
        self._own(layout.etc, group=GROUP)
        if layout.config.exists():
            if profile is not None:
                self.say(f"{layout.config}: kept as it is (--profile {profile} not applied to "
                         "an existing config)")
        else:
            example = _run_robotd(layout, version, ["example-config"])
            self._write_checked_config(version, robot_config(example, profile))
        self._own(layout.config, group=GROUP)
        if not layout.fleet_token.exists():
            self._write(layout.fleet_token, "", 0o600)

    def _write_checked_config(self, version: str, text: str) -> None:
        """Write a new config for a profile the version knows (a bad --profile is refused by
        name, and no config is left); then say what check-config still wants (a delivery
        robot's orders database, a map) for the technician to do."""
        profiles = _run_robotd(self.layout, version, [], python=(
            "from robotd.profiles import PROFILES; print(' '.join(PROFILES.names()))"))
        names = profiles.split()
        profile = _profile_of(text)
        if profile not in names:
            msg = f"--profile {profile}: unknown profile (known: {', '.join(sorted(names))})"
            raise InstallError(msg)
        self._write(self.layout.config, text, 0o640)
        self.say(f"{self.layout.config}: written from robotd example-config (robot.profile = "
                 f"{profile!r})")
        try:
            _run_robotd(self.layout, version, ["check-config", str(self.layout.config)])
        except InstallError as exc:
            self.say(f"to do before starting robotd: {str(exc).split(' failed: ', 1)[-1]}")

    def _udev(self) -> None:
        rules = (self.checkout / UDEV_RULES).read_text()
        self._mkdirs(self.layout.udev_rules.parent)
        if self._write(self.layout.udev_rules, rules, 0o644):
            self.system.run(["udevadm", "control", "--reload"])
            self.system.run(["udevadm", "trigger", "--subsystem-match=tty", "--action=add"])

    def _unit(self) -> None:
        unit = (self.checkout / UNIT_FILE).read_text()
        self._mkdirs(self.layout.unit.parent)
        if self._write(self.layout.unit, unit, 0o644):
            self.system.run(["systemctl", "daemon-reload"])
        if self.layout.wants_link.is_symlink():
            return
        if self.layout.is_real:
            self.system.run(["systemctl", "enable", UNIT])
        else:  # what systemctl enable makes for WantedBy=multi-user.target
            self._mkdirs(self.layout.wants_link.parent)
            self._symlink(self.layout.wants_link, f"/etc/systemd/system/{UNIT}")

    # -- uninstall -----------------------------------------------------------------------
    def uninstall(self, *, purge: bool) -> None:
        layout, s = self.layout, self.system
        manifest = Manifest.load(layout.manifest)
        if layout.unit.exists() or layout.wants_link.is_symlink():
            if layout.is_real:
                s.run(["systemctl", "disable", "--now", UNIT])
            else:
                s.run(["systemctl", "stop", UNIT])
                layout.wants_link.unlink(missing_ok=True)
            layout.unit.unlink(missing_ok=True)
            s.run(["systemctl", "daemon-reload"])
        if layout.udev_rules.exists():
            layout.udev_rules.unlink()
            s.run(["udevadm", "control", "--reload"])
        for name in COMMANDS:
            link = layout.command_link(name)
            if link.is_symlink() and str(link.readlink()).startswith("/opt/robotd/"):
                link.unlink()
        shutil.rmtree(layout.opt, ignore_errors=True)
        if purge:
            shutil.rmtree(layout.etc, ignore_errors=True)
            shutil.rmtree(layout.state_dir, ignore_errors=True)
        if manifest.user:
            s.remove_user(USER)
        elif s.user_exists(USER):
            for group in manifest.memberships:
                s.remove_member(USER, group)
        for group in reversed(manifest.groups):
            s.remove_group(group)
        for directory in sorted(manifest.dirs, key=len, reverse=True):
            path = layout.at(directory)
            if path.is_dir() and not any(path.iterdir()):
                path.rmdir()
        kept = [str(p) for p in (layout.config, layout.fleet_token) if p.exists()]
        if kept:
            self.say(f"kept: {', '.join(kept)} (--purge removes them)")

    # -- files ---------------------------------------------------------------------------
    def _mkdirs(self, path: Path, mode: int = 0o755) -> None:
        """Make ``path`` (with ``mode``) and its missing parents (0755), each listed in the
        manifest."""
        missing = []
        parent = path
        while not parent.exists():
            missing.append(parent)
            parent = parent.parent
        for directory in reversed(missing):
            directory.mkdir()
            os.chmod(directory, mode if directory == path else 0o755)  # not the umask's
            self.manifest.dirs.append("/" + str(directory.relative_to(self.layout.root)))

    def _write(self, path: Path, text: str, mode: int) -> bool:
        """Write ``text`` unless the file holds it already; True when it was written."""
        if path.exists() and path.read_text() == text and (path.stat().st_mode & 0o777) == mode:
            return False
        self._mkdirs(path.parent)
        temporary = path.with_name(f".{path.name}.new")
        temporary.write_text(text)
        os.chmod(temporary, mode)
        temporary.replace(path)
        return True

    def _symlink(self, link: Path, target: str) -> None:
        if link.is_symlink() and str(link.readlink()) == target:
            return
        if link.exists() and not link.is_symlink():
            msg = f"{link}: a file is there already; not replaced by a link to {target}"
            raise InstallError(msg)
        self._mkdirs(link.parent)
        link.unlink(missing_ok=True)
        link.symlink_to(target)

    def _own(self, path: Path, group: str) -> None:
        """Give ``path`` to ``group`` (root keeps it): the service reads, only root writes."""
        gid = self.system.gid(group)
        if not is_root() or gid is None or path.stat().st_gid == gid:
            return
        os.chown(path, 0, gid)


def robot_config(example: str, profile: str | None) -> str:
    """The example config with the profile set and the ports named by the udev rules."""
    lines = example.splitlines(keepends=True)
    section = ""
    for i, line in enumerate(lines):
        stripped = line.strip()
        if stripped.startswith("[") and stripped.endswith("]"):
            section = stripped[1:-1]
        elif section == "robot" and profile and stripped.startswith("profile ="):
            lines[i] = f'profile = "{profile}"\n'
        elif section == "serial" and stripped.startswith(("port =", "#port =")):
            lines[i] = 'port = "/dev/robotd-mcu"\n'
        elif section == "lidar" and stripped.startswith(("port =", "#port =")):
            lines[i] = 'port = "/dev/robotd-lidar"\n'
    return "".join(lines)


def _profile_of(config: str) -> str:
    section = ""
    for line in config.splitlines():
        stripped = line.strip()
        if stripped.startswith("["):
            section = stripped
        elif section == "[robot]" and stripped.startswith("profile ="):
            return stripped.split("=", 1)[1].strip().strip('"')
    return ""


def _run_robotd(layout: Layout, version: str, args: list[str], python: str = "") -> str:
    """The output of the version's ``robotd ARGS`` (or of its Python running ``python``)."""
    robotd = versions.robotd_of(layout, version)
    argv = [str(robotd.with_name("python")), "-c", python] if python else [str(robotd), *args]
    proc = subprocess.run(argv, capture_output=True, text=True, check=False,
                          env=versions.version_env())
    if proc.returncode != 0:
        lines = (proc.stderr.strip() or proc.stdout.strip()).splitlines()
        msg = f"{robotd} {' '.join(args)} failed: {lines[-1] if lines else proc.returncode}"
        raise InstallError(msg)
    return proc.stdout
