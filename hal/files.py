"""Files a robot reads because it was told to, and files it writes where it was told to.

Reading a file that a config or a scenario points to: a regular file, of a bounded size.

A path in a config is input like any other: ``/dev/zero`` as a map would be read until the
memory runs out, a FIFO with no writer would hang the daemon, ``/etc/shadow`` must not be
quoted back in an error. ``read_bounded`` opens the file non-blocking, checks on the open file
(so what is checked is what is read) that it is a regular file, and reads at most
``max_bytes``; every refusal is a ``FileRefused`` that says ``PATH: cannot read: why`` and
never holds a byte of the file.

Writing into a directory someone else may write to too (``--report DIR``) or keeping state
(the state store, a database): ``write_new`` never follows a symbolic link placed where the
file goes, and ``restrict_new`` gives a file its mode whatever the umask.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

_KINDS = {stat.S_IFDIR: "a directory", stat.S_IFCHR: "a character device",
          stat.S_IFBLK: "a block device", stat.S_IFIFO: "a FIFO", stat.S_IFSOCK: "a socket"}


class FileRefused(ValueError):
    """A referenced file that cannot be used: ``PATH: cannot read: why``."""

    def __init__(self, path: str, why: str) -> None:
        super().__init__(f"{path}: cannot read: {why}")
        self.path = path
        self.why = why


def read_bounded(path: str | Path, max_bytes: int, what: str = "file") -> bytes:
    """The bytes of the regular file ``path``, at most ``max_bytes`` of them.

    Args:
        path: the file.
        max_bytes: the largest file of its kind a robot would use (a refusal says so).
        what: what the file is, for the message (``map image``, ``task list``).
    """
    shown = str(path)

    def refuse(why: str) -> FileRefused:
        return FileRefused(shown, why)

    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_NOCTTY)
    except OSError as exc:
        raise refuse(exc.strerror or str(exc)) from None
    try:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            kind = _KINDS.get(stat.S_IFMT(mode), "not a regular file")
            raise refuse(f"{kind}, not a regular file ({what})")
        data = bytearray()
        while len(data) <= max_bytes:
            chunk = os.read(fd, max_bytes + 1 - len(data))
            if not chunk:
                break
            data += chunk
    except OSError as exc:
        raise refuse(exc.strerror or str(exc)) from None
    finally:
        os.close(fd)
    if len(data) > max_bytes:
        raise refuse(f"larger than {max_bytes} bytes, too large for a {what}")
    return bytes(data)


def read_bounded_text(path: str | Path, max_bytes: int, what: str = "file") -> str:
    """``read_bounded`` decoded as UTF-8; text that is not UTF-8 is refused by offset only."""
    data = read_bounded(path, max_bytes, what)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        why = f"not UTF-8 text (line {line}, offset {exc.start}; a {what})"
        raise FileRefused(str(path), why) from None


def write_new(path: str | Path, data: bytes, mode: int = 0o644) -> None:
    """Write ``data`` to ``path`` (replacing a regular file there) with ``mode``, never through
    a symbolic link: a link placed at ``path`` is refused (OSError naming the path)."""
    try:
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC | os.O_NOFOLLOW | os.O_CLOEXEC,
                     mode)
    except OSError:
        if os.path.islink(path):
            msg = f"{path}: is a symbolic link: not written through it"
            raise OSError(msg) from None
        raise
    try:
        os.fchmod(fd, mode)
        view = memoryview(data)
        while view:
            view = view[os.write(fd, view):]
    finally:
        os.close(fd)


def restrict_new(path: str | Path, mode: int = 0o600) -> None:
    """Create ``path`` empty with ``mode`` if it is missing, and give it ``mode`` either way
    (a state file or database: not world-readable, whatever the umask); a symbolic link there
    is refused."""
    fd = os.open(path, os.O_RDONLY | os.O_CREAT | os.O_NOFOLLOW | os.O_CLOEXEC, mode)
    try:
        os.fchmod(fd, mode)
    finally:
        os.close(fd)
