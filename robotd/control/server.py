"""The control socket server: many clients, bounded queues, a stuck client never blocks us."""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import os
from collections import deque
from collections.abc import Awaitable, Callable
from typing import Any

import structlog

from robotd.config.system_limits import socket_path_problem
from robotd.control.access import SOCKET_MODE, claim_path, restrict
from robotd.control.rpc import (
    APP_ERROR,
    INTERNAL_ERROR,
    INVALID_REQUEST,
    METHOD_NOT_FOUND,
    RpcError,
    error_line,
    notification_line,
    parse_request,
    result_line,
)

log = structlog.get_logger(__name__)

MAX_LINE_BYTES = 64 * 1024
_READ_CHUNK = 64 * 1024

Handler = Callable[[dict[str, Any], "Client"], Awaitable[Any]]


class Client:
    """One connection: its subscriptions and a bounded queue of lines to send."""

    def __init__(self, client_id: int, writer: asyncio.StreamWriter, queue_limit: int) -> None:
        self.id = client_id
        self.topics: set[str] = set()
        self._writer = writer
        self._queue: deque[bytes] = deque()
        self._limit = queue_limit
        self._wake = asyncio.Event()
        self.dropped = 0
        self.dropped_total = 0
        self.closed = False

    def send_reply(self, line: bytes) -> bool:
        """Queue a reply; False (and the client is closed) when it stopped reading."""
        if len(self._queue) >= self._limit:
            log.warning("control.client_stuck", client=self.id, queued=len(self._queue))
            self.close()
            return False
        self._queue.append(line)
        self._wake.set()
        return True

    def send_notification(self, line: bytes) -> None:
        """Queue a notification, or count it lost when the client is behind."""
        if len(self._queue) >= self._limit:
            self.dropped += 1
            self.dropped_total += 1
            return
        self._queue.append(line)
        self._wake.set()

    async def write_loop(self) -> None:
        while not self.closed:
            await self._wake.wait()
            self._wake.clear()
            if self.dropped:
                notice = notification_line("dropped", {"count": self.dropped,
                                                       "reason": "client fell behind"})
                self.dropped = 0
                self._writer.write(notice)
            while self._queue:
                self._writer.write(self._queue.popleft())
            await self._writer.drain()

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            self._wake.set()
            self._writer.close()


class ControlServer:
    """Serves JSON-RPC methods on a Unix socket; a supervised service.

    Args:
        path: socket path (its directory is created; mode 0660).
        handlers: method name -> ``async handler(params, client)``; RpcError for a refusal.
        max_clients: connections accepted at once.
        queue_limit: lines queued per client before notifications are dropped.
    """

    name = "control"
    critical = True
    """A robot without its socket cannot be stopped or inspected by a technician: the daemon
    refuses to start rather than run without it."""
    depends_on: tuple[str, ...] = ()

    def __init__(self, path: str, handlers: dict[str, Handler], *, max_clients: int = 64,
                 queue_limit: int = 256, max_line_bytes: int = MAX_LINE_BYTES) -> None:
        self.path = path
        self.handlers = handlers
        self.max_clients = max_clients
        self.queue_limit = queue_limit
        self.max_line_bytes = max_line_bytes
        self.clients: dict[int, Client] = {}
        self._ids = itertools.count(1)

    async def run(self, ready: Callable[[], None]) -> None:
        why = socket_path_problem(self.path)
        if why is not None:
            msg = f"control.socket {self.path!r}: {why}"
            raise OSError(msg)
        try:
            claim_path(self.path)
        except OSError as exc:
            msg = f"control.socket: {exc}"
            raise OSError(msg) from None
        server = await asyncio.start_unix_server(self._serve, path=self.path,
                                                 limit=self.max_line_bytes)
        try:
            restrict(self.path, SOCKET_MODE)
            log.info("control.listening", path=self.path)
            ready()
            await asyncio.get_running_loop().create_future()
        finally:
            server.close()
            for client in list(self.clients.values()):
                client.close()
            with contextlib.suppress(FileNotFoundError):
                os.unlink(self.path)

    def publish(self, topic: str, params: dict[str, Any]) -> None:
        """Send a notification to every client subscribed to ``topic`` (or to ``*``)."""
        line: bytes | None = None
        for client in self.clients.values():
            if topic in client.topics or "*" in client.topics:
                line = line or notification_line(topic, params)
                client.send_notification(line)

    async def _serve(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        if len(self.clients) >= self.max_clients:
            writer.write(error_line(None, APP_ERROR, f"too many clients ({self.max_clients})"))
            with contextlib.suppress(OSError):
                await asyncio.wait_for(writer.drain(), 1.0)
            writer.close()
            return
        client = Client(next(self._ids), writer, self.queue_limit)
        self.clients[client.id] = client
        sender = asyncio.create_task(client.write_loop(), name=f"control-client-{client.id}")
        try:
            await self._read_lines(reader, client)
        except (ConnectionError, OSError):
            pass
        finally:
            self.clients.pop(client.id, None)
            client.close()
            sender.cancel()
            with contextlib.suppress(asyncio.CancelledError, ConnectionError, OSError):
                await sender

    async def _read_lines(self, reader: asyncio.StreamReader, client: Client) -> None:
        buffer = bytearray()
        discarding = False
        while not client.closed:
            chunk = await reader.read(_READ_CHUNK)
            if not chunk:
                return
            buffer += chunk
            while not client.closed:
                end = buffer.find(b"\n")
                if end < 0:
                    if len(buffer) > self.max_line_bytes:
                        if not discarding:
                            self._refuse_long_line(client)
                        discarding = True
                        buffer.clear()
                    break
                line = bytes(buffer[:end])
                del buffer[: end + 1]
                if discarding:
                    discarding = False
                    continue
                if len(line) > self.max_line_bytes:
                    self._refuse_long_line(client)
                    continue
                if line.strip():
                    await self._handle_line(line, client)

    def _refuse_long_line(self, client: Client) -> None:
        client.send_reply(error_line(None, INVALID_REQUEST,
                                     f"line longer than {self.max_line_bytes} bytes refused"))

    async def _handle_line(self, line: bytes, client: Client) -> None:
        try:
            request = parse_request(line)
        except RpcError as exc:
            client.send_reply(error_line(exc.request_id, exc.code, exc.message))
            return
        handler = self.handlers.get(request.method)
        try:
            if handler is None:
                raise RpcError(METHOD_NOT_FOUND, f"method not found: {request.method!r}",
                               {"methods": sorted(self.handlers)})
            result = await handler(request.params, client)
        except RpcError as exc:
            if not request.is_notification:
                client.send_reply(error_line(request.id, exc.code, exc.message, exc.data))
            return
        except Exception as exc:  # a bug in one method must not take the socket down
            log.exception("control.method_failed", method=request.method)
            if not request.is_notification:
                client.send_reply(error_line(request.id, INTERNAL_ERROR,
                                             f"internal error in {request.method}: {exc!r}"))
            return
        if not request.is_notification:
            client.send_reply(result_line(request.id, result))
