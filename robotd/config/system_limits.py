"""Limits set by the operating system, not by robotd, that a config value must fit.

They are checked by ``check-config`` (so the problem shows before the daemon starts) and again
where the value is used (the control server), since a path can also come from ``--socket``.
"""

from __future__ import annotations

import os

UNIX_PATH_MAX = 108
"""Linux ``sizeof(sockaddr_un.sun_path)``: the path's bytes and a terminating NUL."""


def socket_path_problem(path: str) -> str | None:
    """Why ``path`` cannot be a Unix socket's path (too long, empty, a NUL in it), or None."""
    if not path:
        return "empty path: a Unix socket needs one"
    if "\x00" in path:
        return "a NUL character cannot be part of a path"
    try:
        size = len(os.fsencode(path))
    except UnicodeError:
        return "path cannot be encoded for the file system"
    if size + 1 > UNIX_PATH_MAX:
        return (f"path is {size} bytes; a Unix socket path is at most {UNIX_PATH_MAX - 1} "
                f"bytes on Linux ({UNIX_PATH_MAX} with its NUL, sockaddr_un.sun_path)")
    return None
