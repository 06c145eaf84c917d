"""Who may use the control socket: its directory 0750, the socket 0660, group ``robotd``.

Connecting to a Unix socket needs write permission on it and search permission on every
directory above it. So members of the group ``robotd`` (technicians) can do everything
robotctl does, and other users nothing. When the group does not exist (a developer's machine)
the socket keeps the daemon's own group and only that group and its user can connect.
"""

from __future__ import annotations

import grp
import os
import socket
import stat
from pathlib import Path

import structlog

from robotd.config.system_limits import socket_path_problem

log = structlog.get_logger(__name__)

GROUP = "robotd"
SOCKET_MODE = 0o660
RUNTIME_DIR_MODE = 0o750


def group_id(name: str = GROUP) -> int | None:
    """The group's id, or None when there is no such group."""
    try:
        return grp.getgrnam(name).gr_gid
    except KeyError:
        return None


def restrict(path: str | Path, mode: int, *, group: str = GROUP) -> None:
    """chmod ``path`` to ``mode`` and give it to ``group`` when that group exists.

    chown to a group needs the daemon to be a member of it; when it is not (or the unit's
    system call filter refuses chown), the mode still holds and the refusal is logged, not
    raised: the socket stays usable by the daemon's own group."""
    os.chmod(path, mode)
    gid = group_id(group)
    if gid is None:
        log.info("control.no_group", group=group, path=str(path),
                 note="kept the daemon's own group")
        return
    if os.stat(path).st_gid == gid:  # under systemd: Group=robotd made it so already
        return
    try:
        os.chown(path, -1, gid)
    except PermissionError:  # also EPERM from the unit's SystemCallFilter (no @chown)
        log.warning("control.group_refused", group=group, path=str(path),
                    note="the daemon is not a member of the group; kept its own group")


def make_runtime_dir(directory: Path) -> None:
    """Create the socket's directory, 0750 and group ``robotd``; one that exists is left as
    it is (under systemd, RuntimeDirectory= made it with the unit's mode and group)."""
    if directory.is_dir():
        return
    directory.mkdir(parents=True, exist_ok=True)
    restrict(directory, RUNTIME_DIR_MODE)


def socket_problem(path: str) -> str | None:
    """Why the daemon could not listen on ``path``, found before it starts anything; None
    when it can (the length, the directory, a file or another daemon already there)."""
    why = socket_path_problem(path)
    if why is not None:
        return why
    try:
        claim_path(path)
    except OSError as exc:
        return str(exc) if not exc.strerror else f"{exc.strerror}: {exc.filename or path}"
    directory = Path(path).parent
    if not os.access(directory, os.W_OK | os.X_OK):
        return f"cannot create a socket in {directory}: permission denied"
    return None


def claim_path(path: str) -> None:
    """Create the directory; remove a stale socket; refuse if another daemon listens there."""
    target = Path(path)
    make_runtime_dir(target.parent)
    try:
        mode = target.lstat().st_mode
    except FileNotFoundError:
        return
    if not stat.S_ISSOCK(mode):
        msg = f"{path} exists and is not a socket"
        raise OSError(msg)
    probe = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    try:
        probe.connect(path)
    except OSError:
        target.unlink()  # nobody listens: left over from a crash
        return
    finally:
        probe.close()
    msg = f"another robotd is already listening on {path}"
    raise OSError(msg)
