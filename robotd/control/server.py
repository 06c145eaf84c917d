"""The control socket server: many clients, bounded queues, a stuck client never blocks us.

No client, and no crowd of them, may lock a technician out of the e-stop (issue 28): see
``admission`` for who holds a connection and the e-stop lane, ``lines`` for what one client's
bytes may cost the loop.
"""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import os
from collections import deque
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import Any

import structlog

from robotd.config.system_limits import socket_path_problem
from robotd.control.access import SOCKET_MODE, claim_path, restrict
from robotd.control.admission import ClientPolicy, give_way, overdue
from robotd.control.lines import TURN_UNITS, LineSplitter, TooLong, WorkBudget, blank_units
from robotd.control.rpc import (
    APP_ERROR,
    INTERNAL_ERROR,
    INVALID_REQUEST,
    METHOD_NOT_FOUND,
    TOO_MANY_CLIENTS,
    RpcError,
    error_line,
    notification_line,
    parse_request,
    result_line,
)

log = structlog.get_logger(__name__)

MAX_LINE_BYTES = 64 * 1024
_READ_CHUNK = 64 * 1024
_BACKLOG = 256
"""Connections the kernel queues before connect() fails with EAGAIN (capped by somaxconn).
asyncio accepts up to this many in one turn of the loop, so bigger is not better."""
_LANE_GRACE_S = 0.05
"""A silent e-stop lane connection this old gives its place to a newcomer when the lane is full:
robotctl sends its request as it connects, so it has been read long before."""

Handler = Callable[[dict[str, Any], "Client"], Awaitable[Any]]


class Client:
    """One connection: its subscriptions, a bounded queue of lines to send, its activity."""

    def __init__(self, client_id: int, writer: asyncio.StreamWriter, queue_limit: int,
                 now_s: float, budget: WorkBudget) -> None:
        self.id = client_id
        self.topics: set[str] = set()
        self._writer = writer
        self._queue: deque[bytes] = deque()
        self._limit = queue_limit
        self._wake = asyncio.Event()
        self.dropped = 0
        self.dropped_total = 0
        self.closed = False
        self.last_request_s = now_s
        self.writing_since_s: float | None = None
        """Loop time since which its replies wait for it to read (None: they drained)."""
        self.budget = budget

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

    def take_queued(self) -> list[bytes]:
        """The lines queued and not yet written (they are the caller's to send now)."""
        lines = list(self._queue)
        self._queue.clear()
        return lines

    async def write_loop(self) -> None:
        loop = asyncio.get_running_loop()
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
            self.writing_since_s = loop.time()
            await self._writer.drain()
            self.writing_since_s = None

    @property
    def gone(self) -> bool:
        """Whether the connection is lost (its lines read but not yet served are moot)."""
        return self._writer.transport.is_closing()

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            self._wake.set()
            self._writer.close()

    def close_saying(self, line: bytes) -> None:
        """Close after one last line saying why; at once when it does not read (the line
        could never reach it, and its unread replies would hold the socket open)."""
        if self.closed:
            return
        self.closed = True
        self._queue.clear()
        self._wake.set()
        if self.writing_since_s is not None:
            self._writer.transport.abort()
            return
        self._writer.write(line)
        self._writer.close()  # the transport sends what it holds, then closes


@dataclass(slots=True)
class _LaneSeat:
    """A connection in the e-stop lane; ``wait`` while it has sent nothing yet."""

    since_s: float
    wait: asyncio.Timeout | None = None


class ControlServer:
    """Serves JSON-RPC methods on a Unix socket; a supervised service.

    Args:
        path: socket path (its directory is created; mode 0660).
        handlers: method name -> ``async handler(params, client)``; RpcError for a refusal.
        max_clients: connections accepted at once (the e-stop lane comes on top).
        queue_limit: lines queued per client before notifications are dropped.
        policy: idle and stall timeouts, the e-stop lane, the work a client may cost.
    """

    name = "control"
    critical = True
    """A robot without its socket cannot be stopped or inspected by a technician: the daemon
    refuses to start rather than run without it."""
    depends_on: tuple[str, ...] = ()

    def __init__(self, path: str, handlers: dict[str, Handler], *, max_clients: int = 64,
                 queue_limit: int = 256, max_line_bytes: int = MAX_LINE_BYTES,
                 policy: ClientPolicy | None = None) -> None:
        self.path = path
        self.handlers = handlers
        self.max_clients = max_clients
        self.queue_limit = queue_limit
        self.max_line_bytes = max_line_bytes
        self.policy = policy or ClientPolicy()
        self.clients: dict[int, Client] = {}
        self.counts = {"refused": 0, "gave_way": 0, "idle": 0, "stalled": 0,
                       "estop_lane": 0, "throttled": 0}
        """What the socket did to protect itself, since it started."""
        self._ids = itertools.count(1)
        self._lane: list[_LaneSeat] = []
        self._lingering = 0
        self._refused_unlogged = 0

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
                                                 limit=self.max_line_bytes, backlog=_BACKLOG)
        reaper = asyncio.create_task(self._reap(), name="control-reaper")
        try:
            restrict(self.path, SOCKET_MODE)
            log.info("control.listening", path=self.path, max_clients=self.max_clients,
                     estop_reserve=self.policy.estop_reserve,
                     idle_timeout_s=self.policy.idle_timeout_s)
            ready()
            await asyncio.get_running_loop().create_future()
        finally:
            reaper.cancel()
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
        """One connection, start to end; cancelled (the daemon stopping), it just ends: Python
        3.11's streams call ``exception()`` on a cancelled handler and print a traceback."""
        try:
            await self._admit(reader, writer)
        except asyncio.CancelledError:
            writer.transport.abort()

    async def _admit(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        now_s = asyncio.get_running_loop().time()
        if len(self.clients) >= self.max_clients and not self._make_room(now_s):
            if self._lane_seat_free(now_s):
                await self._serve_lane(reader, writer, now_s)
            else:
                await self._refuse(reader, writer, None, self._full())
            return
        policy = self.policy
        client = Client(next(self._ids), writer, self.queue_limit, now_s,
                        WorkBudget(policy.lines_per_s, policy.lines_burst, now_s))
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
        """Serve a client's requests, yielding to the loop every ``TURN_UNITS`` of work and
        reading no faster than its budget allows."""
        loop = asyncio.get_running_loop()
        splitter = LineSplitter(self.max_line_bytes)
        while not client.closed:
            chunk = await reader.read(_READ_CHUNK)
            if not chunk:
                return
            lines, blank = splitter.feed(chunk)
            units = blank_units(blank)
            for line in lines:
                if client.closed or client.gone:
                    return
                if isinstance(line, TooLong):
                    self._refuse_long_line(client)
                else:
                    client.last_request_s = loop.time()
                    await self._handle_line(line, client)
                units += 1
                if units >= TURN_UNITS:
                    await self._spend(client, units)
                    units = 0
            await self._spend(client, units)

    async def _spend(self, client: Client, units: float) -> None:
        """Yield to the loop; wait as well when the client has spent its budget."""
        loop = asyncio.get_running_loop()
        wait_s = client.budget.spend(units, loop.time())
        if wait_s and not client.budget.throttled_before:
            client.budget.throttled_before = True
            self.counts["throttled"] += 1
            log.warning("control.client_throttled", client=client.id,
                        lines_per_s=client.budget.rate_per_s, wait_ms=round(wait_s * 1000, 1))
        await asyncio.sleep(wait_s)

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

    # --- who holds a connection ---------------------------------------------------------

    def _full(self, note: str = "") -> str:
        return f"too many clients ({self.max_clients} connected){note}; try again shortly"

    def _refusal(self, request_id: Any, message: str) -> bytes:
        return error_line(request_id, APP_ERROR, message,
                          {"reason": TOO_MANY_CLIENTS, "max_clients": self.max_clients})

    def _make_room(self, now_s: float) -> bool:
        """Close the client idle or stalled longest, if any has been long enough."""
        found = give_way(self.clients.values(), now_s, self.policy)
        if found is None:
            return False
        client, reason, seconds = found
        assert isinstance(client, Client)
        self.counts["gave_way"] += 1
        log.info("control.client_gave_way", client=client.id, reason=reason,
                 seconds=round(seconds, 3), clients=len(self.clients))
        self._close(client, f"connection closed: {reason} for {seconds:.1f} s and the socket "
                            f"is full ({self.max_clients} clients)", reason)
        return True

    def _close(self, client: Client, message: str, reason: str) -> None:
        self.clients.pop(client.id, None)
        client.close_saying(error_line(None, APP_ERROR, message, {"reason": reason}))

    async def _reap(self) -> None:
        """Close idle and stalled connections; say how many were refused since last time."""
        loop = asyncio.get_running_loop()
        policy = self.policy
        while True:
            await asyncio.sleep(policy.reap_every_s)
            for client, reason, seconds in overdue(list(self.clients.values()), loop.time(),
                                                   policy):
                assert isinstance(client, Client)
                self.counts[reason] += 1
                if reason == "stalled":
                    log.warning("control.client_stalled", client=client.id,
                                stalled_s=round(seconds, 3))
                    message = f"connection closed: replies unread for {seconds:.1f} s"
                else:
                    log.info("control.client_idle", client=client.id, idle_s=round(seconds, 3))
                    message = (f"connection closed: no request for {seconds:.1f} s (idle "
                               f"timeout {policy.idle_timeout_s:g} s)")
                self._close(client, message, reason)
            if self._refused_unlogged:
                log.warning("control.clients_refused", count=self._refused_unlogged,
                            clients=len(self.clients), max_clients=self.max_clients,
                            estop_lane=len(self._lane))
                self._refused_unlogged = 0

    async def _refuse(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter,
                      request_id: Any, message: str) -> None:
        self.counts["refused"] += 1
        self._refused_unlogged += 1
        await self._finish(reader, writer, [self._refusal(request_id, message)])

    async def _finish(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter,
                      lines: list[bytes]) -> None:
        """Send the last lines and close cleanly: end our side, then read and drop what the
        client still sends, briefly, so that its request meets no closed socket."""
        for line in lines:
            writer.write(line)
        if self._lingering >= self.policy.lingering_max:
            writer.close()
            return
        self._lingering += 1
        try:
            if writer.can_write_eof():
                writer.write_eof()
            async with asyncio.timeout(self.policy.refusal_linger_s):
                while await reader.read(_READ_CHUNK):
                    pass
        except (TimeoutError, ConnectionError, OSError):
            pass
        finally:
            self._lingering -= 1
            writer.close()

    # --- the e-stop lane ----------------------------------------------------------------

    def _lane_seat_free(self, now_s: float) -> bool:
        """Whether a newcomer gets a seat in the e-stop lane; the oldest silent seat is
        given up for it when the lane is full."""
        if len(self._lane) < self.policy.estop_reserve:
            return True
        silent = [s for s in self._lane
                  if s.wait is not None and now_s - s.since_s >= _LANE_GRACE_S]
        if not silent:
            return False
        oldest = min(silent, key=lambda s: s.since_s)
        assert oldest.wait is not None
        oldest.wait.reschedule(now_s)  # its wait ends now: it is refused
        oldest.wait = None
        return True

    async def _serve_lane(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter,
                          now_s: float) -> None:
        """Past ``max_clients``: serve one ``estop`` request, refuse anything else."""
        seat = _LaneSeat(now_s)
        self._lane.append(seat)
        try:
            line: bytes | TooLong | None = None
            with contextlib.suppress(TimeoutError, ConnectionError, OSError):
                async with asyncio.timeout(self.policy.lane_timeout_s) as seat.wait:
                    line = await _first_line(reader, self.max_line_bytes)
            seat.wait = None
            request_id, method = _peek(line)
            if method != "estop":
                await self._refuse(reader, writer, request_id,
                                   self._full(": past them only estop is served"))
                return
            budget = WorkBudget(self.policy.lines_per_s, self.policy.lines_burst, now_s)
            client = Client(next(self._ids), writer, self.queue_limit, now_s, budget)
            assert isinstance(line, bytes)
            await self._handle_line(line, client)
            loop = asyncio.get_running_loop()
            self.counts["estop_lane"] += 1
            log.warning("control.estop_lane", client=client.id, clients=len(self.clients),
                        ms=round((loop.time() - now_s) * 1000, 3))
            await self._finish(reader, writer, client.take_queued())
        finally:
            self._lane.remove(seat)


async def _first_line(reader: asyncio.StreamReader, max_line_bytes: int) -> bytes | TooLong | None:
    """The first non-blank line a client sends; None if it closes first."""
    splitter = LineSplitter(max_line_bytes)
    while chunk := await reader.read(_READ_CHUNK):
        lines, _blank = splitter.feed(chunk)
        if lines:
            return lines[0]
    return None


def _peek(line: bytes | TooLong | None) -> tuple[Any, str | None]:
    """The request's id and method, as far as they can be read (None, None if not)."""
    if not isinstance(line, bytes):
        return None, None
    try:
        request = parse_request(line)
    except RpcError as exc:
        return exc.request_id, None
    return (None if request.is_notification else request.id), request.method
