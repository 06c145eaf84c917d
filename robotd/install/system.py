"""The system changes an install makes outside its files: accounts and service commands.

``RealSystem`` runs groupadd/useradd/usermod, systemctl and udevadm. ``RootSystem`` (``--root
DIR``) runs none of them: it edits ``DIR/etc/passwd`` and ``DIR/etc/group`` as those tools
would, and writes each service command to ``opt/robotd/root-commands.log`` under DIR, so a
test can check a whole install in a temporary directory.
"""

from __future__ import annotations

import grp
import os
import pwd
import subprocess
from pathlib import Path
from typing import Protocol

from robotd.install.layout import Layout

# useradd --system picks ids below 1000, from the top down.
SYSTEM_ID_MAX = 999
SYSTEM_ID_MIN = 100


class InstallError(Exception):
    """A step that cannot be done: the message says which and why, in one line."""


class System(Protocol):
    def group_exists(self, name: str) -> bool: ...
    def add_group(self, name: str) -> None: ...
    def remove_group(self, name: str) -> None: ...
    def user_exists(self, name: str) -> bool: ...
    def add_user(self, name: str, group: str, home: str, shell: str) -> None: ...
    def remove_user(self, name: str) -> None: ...
    def groups_of(self, user: str) -> set[str]: ...
    def add_member(self, user: str, group: str) -> None: ...
    def remove_member(self, user: str, group: str) -> None: ...
    def gid(self, group: str) -> int | None: ...
    def run(self, argv: list[str]) -> None: ...


def _run(argv: list[str]) -> None:
    try:
        proc = subprocess.run(argv, capture_output=True, text=True, check=False)
    except FileNotFoundError:
        msg = f"{argv[0]}: command not found (needed to run: {' '.join(argv)})"
        raise InstallError(msg) from None
    if proc.returncode != 0:
        why = (proc.stderr.strip() or proc.stdout.strip()).splitlines()
        msg = f"{' '.join(argv)} failed (exit {proc.returncode}): {why[-1] if why else '-'}"
        raise InstallError(msg)


class RealSystem:
    """This machine's accounts and services, through the usual tools."""

    def group_exists(self, name: str) -> bool:
        return self.gid(name) is not None

    def gid(self, group: str) -> int | None:
        try:
            return grp.getgrnam(group).gr_gid
        except KeyError:
            return None

    def add_group(self, name: str) -> None:
        _run(["groupadd", "--system", name])

    def remove_group(self, name: str) -> None:
        _run(["groupdel", name])

    def user_exists(self, name: str) -> bool:
        try:
            pwd.getpwnam(name)
        except KeyError:
            return False
        return True

    def add_user(self, name: str, group: str, home: str, shell: str) -> None:
        _run(["useradd", "--system", "--no-create-home", "--home-dir", home, "--shell", shell,
              "--gid", group, name])

    def remove_user(self, name: str) -> None:
        _run(["userdel", name])

    def groups_of(self, user: str) -> set[str]:
        return {g.gr_name for g in grp.getgrall() if user in g.gr_mem}

    def add_member(self, user: str, group: str) -> None:
        _run(["usermod", "--append", "--groups", group, user])

    def remove_member(self, user: str, group: str) -> None:
        _run(["gpasswd", "--delete", user, group])

    def run(self, argv: list[str]) -> None:
        _run(argv)


class RootSystem:
    """Accounts as lines of ``ROOT/etc/passwd`` and ``ROOT/etc/group``; commands recorded."""

    def __init__(self, layout: Layout) -> None:
        self.layout = layout
        self.passwd = layout.at("/etc/passwd")
        self.group = layout.at("/etc/group")

    def _rows(self, path: Path) -> list[list[str]]:
        if not path.exists():
            return []
        return [line.split(":") for line in path.read_text().splitlines() if line.strip()]

    def _write_rows(self, path: Path, rows: list[list[str]]) -> None:
        if not rows:  # made by us and now empty: gone, as it was before
            path.unlink(missing_ok=True)
            return
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text("".join(":".join(row) + "\n" for row in rows))

    def _free_id(self, used: set[int]) -> int:
        for candidate in range(SYSTEM_ID_MAX, SYSTEM_ID_MIN - 1, -1):
            if candidate not in used:
                return candidate
        msg = f"{self.group}: no free system id between {SYSTEM_ID_MIN} and {SYSTEM_ID_MAX}"
        raise InstallError(msg)

    def gid(self, group: str) -> int | None:
        for row in self._rows(self.group):
            if row[0] == group:
                return int(row[2])
        return None

    def group_exists(self, name: str) -> bool:
        return self.gid(name) is not None

    def add_group(self, name: str) -> None:
        rows = self._rows(self.group)
        gid = self._free_id({int(row[2]) for row in rows})
        self._write_rows(self.group, [*rows, [name, "x", str(gid), ""]])

    def remove_group(self, name: str) -> None:
        self._write_rows(self.group, [r for r in self._rows(self.group) if r[0] != name])

    def user_exists(self, name: str) -> bool:
        return any(row[0] == name for row in self._rows(self.passwd))

    def add_user(self, name: str, group: str, home: str, shell: str) -> None:
        rows = self._rows(self.passwd)
        uid = self._free_id({int(row[2]) for row in rows})
        gid = self.gid(group)
        if gid is None:
            msg = f"{self.group}: no group {group!r} for user {name!r}"
            raise InstallError(msg)
        self._write_rows(self.passwd, [*rows, [name, "x", str(uid), str(gid), "", home, shell]])

    def remove_user(self, name: str) -> None:
        """The user and its memberships, as userdel removes them."""
        self._write_rows(self.passwd, [r for r in self._rows(self.passwd) if r[0] != name])
        for group in self.groups_of(name):
            self.remove_member(name, group)

    def groups_of(self, user: str) -> set[str]:
        return {row[0] for row in self._rows(self.group) if user in row[3].split(",")}

    def _edit_members(self, user: str, group: str, add: bool) -> None:
        rows = self._rows(self.group)
        for row in rows:
            if row[0] == group:
                members = [m for m in row[3].split(",") if m and m != user]
                row[3] = ",".join([*members, user] if add else members)
        self._write_rows(self.group, rows)

    def add_member(self, user: str, group: str) -> None:
        self._edit_members(user, group, add=True)

    def remove_member(self, user: str, group: str) -> None:
        self._edit_members(user, group, add=False)

    def run(self, argv: list[str]) -> None:
        log = self.layout.command_log
        if not log.parent.exists():  # uninstall, after /opt/robotd is gone: said, not kept
            print(f"--root: would run: {' '.join(argv)}")
            return
        with log.open("a") as out:
            out.write(" ".join(argv) + "\n")


def system_for(layout: Layout) -> System:
    """The real system for ``/``; the file-backed one for any other root."""
    return RealSystem() if layout.is_real else RootSystem(layout)


def is_root() -> bool:
    return os.geteuid() == 0
