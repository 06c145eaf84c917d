"""robotctl's side of the control socket: a blocking JSON-RPC client, and what can go wrong."""

from __future__ import annotations

import collections
import itertools
import json
import os
import select
import socket
import stat
import struct
import time
from typing import Any

from robotd.control.rpc import CLOSED_REASONS, ESTOP_SOCKET_SUFFIX, TOO_MANY_CLIENTS
from robotd.ctl.retry import Backoff

DEFAULT_SOCKET = "/run/robotd/control.sock"
EXIT_OK, EXIT_ERROR, EXIT_USAGE, EXIT_CONNECT = 0, 1, 2, 3
CONTROL_FIRST_S = 0.3
"""How long ``estop`` waits for room in the control socket's listen queue before it goes to
the e-stop socket beside it (a refusal sends it there at once)."""


class CannotConnect(Exception):
    pass


class Refused(CannotConnect):
    """The daemon took no request on this connection (it had no room): nothing was done."""


class DaemonError(Exception):
    def __init__(self, error: dict[str, Any]) -> None:
        self.error = error
        super().__init__(error.get("message", "error"))


class Connection:
    """A blocking JSON-RPC client over the Unix socket (robotctl is a short-lived process).

    A connect that fails for a moment (``EAGAIN``: the daemon's listen queue is full;
    ``ECONNREFUSED``: it is between two sockets) and a first request refused for want of room
    ("too many clients": it was not carried out) are tried again, backing off, for up to
    ``retry.budget_s`` (1 s); then the reason is raised as ``CannotConnect``. With
    ``retry_refusals=False`` a refusal is raised at once (``estop`` has a socket to go to).
    """

    def __init__(self, path: str, timeout_s: float, *, retry: Backoff | None = None,
                 retry_refusals: bool = True) -> None:
        self.path = path
        self._ids = itertools.count(1)
        self._timeout_s = timeout_s
        self._retry = retry or Backoff()
        self._retry_refusals = retry_refusals
        self._answered = False
        self._buffer = bytearray()
        self._notifications: collections.deque[dict[str, Any]] = collections.deque()
        self._sock = self._connect()

    def _connect(self) -> socket.socket:
        while True:
            sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            # A blocking connect bounded by SO_SNDTIMEO: while the daemon's listen queue is
            # full the kernel waits for room, in turn with the others, rather than failing
            # at once with EAGAIN (a non-blocking connect) as robotctl used to.
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDTIMEO,
                            _timeval(min(self._timeout_s, max(self._retry.left_s, 0.05))))
            try:
                sock.connect(self.path)
                sock.settimeout(self._timeout_s)
            except (BlockingIOError, ConnectionRefusedError) as exc:
                sock.close()
                if _is_socket(self.path) and self._retry.again():
                    continue
                raise _cannot_connect(self.path, exc) from None
            except OSError as exc:
                sock.close()
                raise _cannot_connect(self.path, exc) from None
            return sock

    def call(self, method: str, params: dict[str, Any] | None = None) -> Any:
        while True:
            try:
                reply = self._exchange(method, params)
            except Refused as exc:
                if self._answered or not self._retry_refusals or not self._retry.again():
                    tries = f" ({self._retry.attempts} attempts)" if not self._answered else ""
                    raise Refused(f"robotd refused the connection: {exc}{tries}") from None
                self._reconnect()
                continue
            self._answered = True
            if "error" in reply:
                raise DaemonError(reply["error"])
            return reply.get("result")

    def _reconnect(self) -> None:
        self._sock.close()
        self._buffer.clear()
        self._sock = self._connect()

    def _exchange(self, method: str, params: dict[str, Any] | None) -> dict[str, Any]:
        """Send one request and return its reply; Refused when the daemon had no room."""
        request_id = next(self._ids)
        message = {"jsonrpc": "2.0", "id": request_id, "method": method, "params": params or {}}
        try:
            try:
                self._sock.sendall(json.dumps(message).encode() + b"\n")
            except (BrokenPipeError, ConnectionResetError) as exc:
                if self._answered:
                    raise
                # Closed before it read a line from us: it said why first, or it is going away.
                raise Refused(self._why_closed() or str(exc)) from None
            while True:
                line = self._readline(self._timeout_s)
                if line is None:
                    raise TimeoutError
                reply: dict[str, Any] = json.loads(line)
                if reply.get("id") == request_id:
                    break
                if "error" in reply and reply.get("id") is None:  # about this connection
                    break
                if "method" in reply and "id" not in reply:  # a notification: kept for later
                    self._notifications.append(reply)
        except TimeoutError:
            raise CannotConnect(f"robotd did not answer {method!r} in time") from None
        except OSError as exc:
            raise CannotConnect(f"connection to {self.path} failed: {exc}") from None
        _raise_if_closed(reply)
        return reply

    def _why_closed(self) -> str | None:
        """The refusal the daemon sent before it closed, if it is there to read."""
        try:
            line = self._readline(0.0)
        except (CannotConnect, OSError):
            return None
        if line is None:
            return None
        try:
            error = json.loads(line).get("error") or {}
        except (ValueError, AttributeError):
            return None
        message = error.get("message") if isinstance(error, dict) else None
        return message if isinstance(message, str) else None

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
            _raise_if_closed(message)
            if "method" in message and "id" not in message:
                self._notifications.append(message)
        return self._notifications.popleft()

    def _readline(self, timeout_s: float) -> bytes | None:
        """One line from the daemon; None after ``timeout_s`` with no whole line (what came
        so far is kept: a timeout never loses part of a line)."""
        deadline = time.monotonic() + timeout_s
        while (end := self._buffer.find(b"\n")) < 0:
            left = max(0.0, deadline - time.monotonic())
            if not select.select([self._sock], [], [], left)[0]:
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


def call_estop(path: str, timeout_s: float, params: dict[str, Any]) -> Any:
    """``estop`` through the control socket at ``path``, or through the e-stop socket beside
    it (``PATH.estop``) when the control socket cannot take it: full, its listen queue full
    (a connect storm), or no answer in time. Sending it twice is harmless: it is a latch."""
    try:
        conn = Connection(path, timeout_s, retry=Backoff(CONTROL_FIRST_S), retry_refusals=False)
    except CannotConnect as exc:
        return _estop_beside(path, timeout_s, params, exc)
    try:
        return conn.call("estop", params)
    except CannotConnect as exc:
        return _estop_beside(path, timeout_s, params, exc)
    finally:
        conn.close()


def _estop_beside(path: str, timeout_s: float, params: dict[str, Any],
                  why: CannotConnect) -> Any:
    estop_path = path + ESTOP_SOCKET_SUFFIX
    if not _is_socket(estop_path):  # a daemon without one, or none at all: the first reason
        raise why
    conn = None
    try:
        conn = Connection(estop_path, timeout_s)
        return conn.call("estop", params)
    except CannotConnect as exc:
        raise CannotConnect(f"{why}; and through {estop_path}: {exc}") from None
    finally:
        if conn is not None:
            conn.close()


def _raise_if_closed(message: dict[str, Any]) -> None:
    """Refused for want of room (nothing was done) or CannotConnect when the daemon closed
    the connection (idle, stalled); nothing for any other message."""
    error = message.get("error")
    if not isinstance(error, dict):
        return
    reason = _reason(error)
    if reason == TOO_MANY_CLIENTS:
        raise Refused(str(error.get("message")))
    if reason in CLOSED_REASONS and message.get("id") is None:
        raise CannotConnect(f"robotd closed the connection: {error.get('message')}")


def _timeval(seconds: float) -> bytes:
    """A ``struct timeval`` for SO_SNDTIMEO."""
    whole = int(seconds)
    return struct.pack("@ll", whole, int((seconds - whole) * 1_000_000))


def _reason(error: dict[str, Any]) -> object:
    data = error.get("data")
    return data.get("reason") if isinstance(data, dict) else None


def _is_socket(path: str) -> bool:
    try:
        return stat.S_ISSOCK(os.stat(path).st_mode)
    except OSError:
        return False


def _cannot_connect(path: str, exc: OSError) -> CannotConnect:
    """What to tell a technician about a connect that failed, and what to check."""
    if isinstance(exc, FileNotFoundError):
        return CannotConnect(f"no control socket at {path}: is robotd running? "
                             "(systemctl status robotd; or give --socket PATH)")
    if isinstance(exc, PermissionError):
        return CannotConnect(f"permission denied on {path}: the socket is mode 0660, group "
                             "robotd; join that group (sudo usermod -aG robotd $USER, log in "
                             "again) or use sudo")
    if isinstance(exc, ConnectionRefusedError):
        if os.path.exists(path) and not _is_socket(path):
            return CannotConnect(f"{path} is not a socket (a regular file or another kind "
                                 "of file): check --socket / control.socket")
        return CannotConnect(f"nothing listens on {path}: robotd is not running (a stale "
                             "socket left by a crash?)")
    if isinstance(exc, BlockingIOError):
        return CannotConnect(f"cannot connect to {path}: robotd's queue of new connections "
                             "stayed full (a connect storm?); try again")
    return CannotConnect(f"cannot connect to {path}: {exc}")
