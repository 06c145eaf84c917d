"""robotctl's side of the control socket: a blocking JSON-RPC client, and what can go wrong."""

from __future__ import annotations

import collections
import itertools
import json
import os
import select
import socket
import stat
import time
from typing import Any

DEFAULT_SOCKET = "/run/robotd/control.sock"
EXIT_OK, EXIT_ERROR, EXIT_USAGE, EXIT_CONNECT = 0, 1, 2, 3


class CannotConnect(Exception):
    pass


class DaemonError(Exception):
    def __init__(self, error: dict[str, Any]) -> None:
        self.error = error
        super().__init__(error.get("message", "error"))


class Connection:
    """A blocking JSON-RPC client over the Unix socket (robotctl is a short-lived process)."""

    def __init__(self, path: str, timeout_s: float) -> None:
        self.path = path
        self._ids = itertools.count(1)
        self._sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        self._sock.settimeout(timeout_s)
        try:
            self._sock.connect(path)
        except FileNotFoundError:
            raise CannotConnect(f"no control socket at {path}: is robotd running? "
                                "(systemctl status robotd; or give --socket PATH)") from None
        except PermissionError:
            raise CannotConnect(f"permission denied on {path}: the socket is mode 0660, group "
                                "robotd; join that group (sudo usermod -aG robotd $USER, log in "
                                "again) or use sudo") from None
        except ConnectionRefusedError:
            if not stat.S_ISSOCK(os.stat(path).st_mode):
                raise CannotConnect(f"{path} is not a socket (a regular file or another kind "
                                    "of file): check --socket / control.socket") from None
            raise CannotConnect(f"nothing listens on {path}: robotd is not running (a stale "
                                "socket left by a crash?)") from None
        except OSError as exc:
            raise CannotConnect(f"cannot connect to {path}: {exc}") from None
        self._timeout_s = timeout_s
        self._buffer = bytearray()
        self._notifications: collections.deque[dict[str, Any]] = collections.deque()

    def call(self, method: str, params: dict[str, Any] | None = None) -> Any:
        request_id = next(self._ids)
        message = {"jsonrpc": "2.0", "id": request_id, "method": method, "params": params or {}}
        try:
            self._sock.sendall(json.dumps(message).encode() + b"\n")
            while True:
                line = self._readline(self._timeout_s)
                if line is None:
                    raise TimeoutError
                reply = json.loads(line)
                if reply.get("id") == request_id:
                    break
                if "method" in reply and "id" not in reply:  # a notification: kept for later
                    self._notifications.append(reply)
        except TimeoutError:
            raise CannotConnect(f"robotd did not answer {method!r} in time") from None
        except OSError as exc:
            raise CannotConnect(f"connection to {self.path} failed: {exc}") from None
        if "error" in reply:
            raise DaemonError(reply["error"])
        return reply.get("result")

    def next_notification(self, timeout_s: float) -> dict[str, Any] | None:
        """The next notification of a subscription, or None when none came in ``timeout_s``."""
        while not self._notifications:
            try:
                line = self._readline(timeout_s)
            except OSError as exc:
                raise CannotConnect(f"connection to {self.path} failed: {exc}") from None
            if line is None:
                return None
            message = json.loads(line)
            if "method" in message and "id" not in message:
                self._notifications.append(message)
        return self._notifications.popleft()

    def _readline(self, timeout_s: float) -> bytes | None:
        """One line from the daemon; None after ``timeout_s`` with no whole line (what came
        so far is kept: a timeout never loses part of a line)."""
        deadline = time.monotonic() + timeout_s
        while (end := self._buffer.find(b"\n")) < 0:
            left = deadline - time.monotonic()
            if left <= 0 or not select.select([self._sock], [], [], left)[0]:
                return None
            chunk = self._sock.recv(65536)
            if not chunk:
                raise CannotConnect(f"robotd closed the connection on {self.path}")
            self._buffer += chunk
        line = bytes(self._buffer[:end])
        del self._buffer[:end + 1]
        return line

    def close(self) -> None:
        self._sock.close()
