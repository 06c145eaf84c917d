"""The e-stop socket: a second socket beside the control socket that serves only ``estop``.

A connect storm can keep the control socket's listen queue full, and then no connect gets in,
however the daemon treats the connections it accepts. The e-stop socket (``PATH.estop``, same
mode and group) has a queue of its own that only ``robotctl estop`` uses, when the control
socket cannot take it. One request per connection: ``estop`` is served, anything else refused.
"""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import os
from collections.abc import Awaitable, Callable
from typing import Any

import structlog

from robotd.config.system_limits import socket_path_problem
from robotd.control.access import SOCKET_MODE, claim_path, restrict
from robotd.control.admission import ClientPolicy
from robotd.control.client import Client, close_cleanly
from robotd.control.lines import LineSplitter, TooLong, WorkBudget
from robotd.control.rpc import (
    APP_ERROR,
    ESTOP_SOCKET_SUFFIX,
    METHOD_NOT_FOUND,
    RpcError,
    error_line,
    parse_request,
    result_line,
)

log = structlog.get_logger(__name__)

EstopHandler = Callable[[dict[str, Any], Client], Awaitable[Any]]
_BACKLOG = 16


class EstopSocket:
    """Serves ``estop`` alone on ``control_path + ".estop"``.

    Args:
        control_path: the control socket's path; this one is beside it.
        estop: the control socket's ``estop`` handler.
        policy: ``wait_s`` to send the request, ``estop_socket_max`` connections at once.
    """

    def __init__(self, control_path: str, estop: EstopHandler, policy: ClientPolicy,
                 ids: itertools.count[int]) -> None:
        self.path = control_path + ESTOP_SOCKET_SUFFIX
        self.estop = estop
        self.policy = policy
        self.served = 0
        self._ids = ids
        self._open = 0
        self._server: asyncio.Server | None = None

    async def start(self) -> bool:
        """Listen; False (and logged: the control socket still serves estop) if it cannot."""
        why = socket_path_problem(self.path)
        try:
            if why is None:
                claim_path(self.path)
                self._server = await asyncio.start_unix_server(
                    self._serve, path=self.path, limit=4096, backlog=_BACKLOG)
                restrict(self.path, SOCKET_MODE)
        except OSError as exc:
            why = str(exc)
            self.close()  # not left listening with the wrong mode
            self._server = None
        if why is not None:
            log.warning("control.estop_socket_unavailable", path=self.path, why=why)
            return False
        log.info("control.estop_socket", path=self.path)
        return True

    def close(self) -> None:
        if self._server is not None:
            self._server.close()
            with contextlib.suppress(FileNotFoundError):
                os.unlink(self.path)

    async def _serve(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        try:
            await self._one_request(reader, writer)
        except asyncio.CancelledError:  # the daemon stopping (see ControlServer._serve)
            writer.transport.abort()

    async def _one_request(self, reader: asyncio.StreamReader,
                           writer: asyncio.StreamWriter) -> None:
        loop = asyncio.get_running_loop()
        started_s = loop.time()
        if self._open >= self.policy.estop_socket_max:
            writer.write(error_line(None, APP_ERROR, "e-stop socket busy; try again"))
            writer.close()
            return
        self._open += 1
        try:
            line: bytes | TooLong | None = None
            with contextlib.suppress(TimeoutError, ConnectionError, OSError):
                async with asyncio.timeout(self.policy.wait_s):
                    line = await _first_line(reader)
            reply = await self._answer(line, writer, started_s)
            if reply is not None:
                await close_cleanly(reader, writer, [reply], self.policy.refusal_linger_s)
            else:
                writer.close()
        finally:
            self._open -= 1

    async def _answer(self, line: bytes | TooLong | None, writer: asyncio.StreamWriter,
                      started_s: float) -> bytes | None:
        """The reply line (None for a notification)."""
        if not isinstance(line, bytes):
            return error_line(None, APP_ERROR, "no estop request in time on the e-stop socket")
        try:
            request = parse_request(line)
        except RpcError as exc:
            return error_line(exc.request_id, exc.code, exc.message)
        request_id = None if request.is_notification else request.id
        if request.method != "estop":
            return error_line(request_id, METHOD_NOT_FOUND, f"the e-stop socket serves only "
                              f"estop, not {request.method!r}; use the control socket")
        now_s = asyncio.get_running_loop().time()
        client = Client(next(self._ids), writer, 1, now_s, WorkBudget(1, 1, now_s))
        try:
            result = await self.estop(request.params, client)
        except RpcError as exc:
            return error_line(request_id, exc.code, exc.message, exc.data)
        except Exception as exc:  # a bug in estop must not take the socket down
            log.exception("control.method_failed", method="estop", socket="estop")
            return error_line(request_id, APP_ERROR, f"internal error in estop: {exc!r}")
        self.served += 1
        log.warning("control.estop_socket_served", ms=round(
            (asyncio.get_running_loop().time() - started_s) * 1000, 3))
        return None if request.is_notification else result_line(request_id, result)


async def _first_line(reader: asyncio.StreamReader) -> bytes | TooLong | None:
    splitter = LineSplitter(4096)
    while chunk := await reader.read(4096):
        lines, _blank = splitter.feed(chunk)
        if lines:
            return lines[0]
    return None
