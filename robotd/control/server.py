"""The control socket server: many clients, bounded queues, a stuck client never blocks us.

No client, and no crowd of them, may lock a technician out of the e-stop (issue 28):
``admission`` says who holds a connection, ``overflow`` who waits past ``max_clients``,
``lines`` what one client's bytes may cost the loop, ``estop_socket`` the socket beside this
one that serves only ``estop``. Past the limit an ``estop`` is still served, whoever sends it.
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
from robotd.control.admission import ClientPolicy, give_way, overdue
from robotd.control.client import Client, close_cleanly
from robotd.control.estop_socket import EstopSocket
from robotd.control.lines import TURN_UNITS, LineSplitter, TooLong, WorkBudget, blank_units
from robotd.control.overflow import Seat, WaitingRoom
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

__all__ = ["MAX_LINE_BYTES", "Client", "ControlServer", "Handler"]

log = structlog.get_logger(__name__)

MAX_LINE_BYTES = 64 * 1024
_READ_CHUNK = 64 * 1024
_BACKLOG = 256
"""Connections the kernel queues before connect() has to wait (capped by somaxconn).
asyncio accepts up to this many in one turn of the loop, so bigger is not better."""

Handler = Callable[[dict[str, Any], Client], Awaitable[Any]]
Lines = list[bytes | TooLong]


class ControlServer:
    """Serves JSON-RPC methods on a Unix socket; a supervised service.

    Args:
        path: socket path (its directory is created; mode 0660).
        handlers: method name -> ``async handler(params, client)``; RpcError for a refusal.
        max_clients: connections served at once (the waiting room on top).
        queue_limit: lines queued per client before notifications are dropped.
        policy: idle and stall timeouts, what is past the limit, what a client may cost.
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
        self.counts = {"refused": 0, "waited": 0, "gave_way": 0, "idle": 0, "stalled": 0,
                       "estop_past_limit": 0, "throttled": 0}
        """What the socket did to keep itself usable, since it started."""
        self._ids = itertools.count(1)
        self._room = WaitingRoom(self.policy.wait_max)
        self._promised = 0
        """Places handed to waiting connections that have not taken them yet."""
        self._lingering = 0
        self._refused_unlogged = 0
        estop = handlers.get("estop")
        self.estop_socket = None if estop is None else EstopSocket(path, estop, self.policy,
                                                                   self._ids)

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
            if self.estop_socket is not None:
                await self.estop_socket.start()
            log.info("control.listening", path=self.path, max_clients=self.max_clients,
                     wait_max=self.policy.wait_max, idle_timeout_s=self.policy.idle_timeout_s)
            ready()
            await asyncio.get_running_loop().create_future()
        finally:
            reaper.cancel()
            server.close()
            if self.estop_socket is not None:
                self.estop_socket.close()
            for client in list(self.clients.values()):
                client.close()
            with contextlib.suppress(FileNotFoundError):
                os.unlink(self.path)

    def figures(self) -> dict[str, int]:
        """What the socket holds now (places, seats, promised places, refusals lingering) and
        ``counts`` since it started."""
        return {"clients": len(self.clients), "waiting": len(self._room),
                "queued": self._room.queued, "promised": self._promised,
                "lingering": self._lingering, **self.counts}

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
        if self._place_free(now_s):
            await self._session(reader, writer, LineSplitter(self.max_line_bytes), [], now_s)
            return
        seat = self._room.seat(now_s)
        if seat is None:
            await self._refuse(reader, writer, now_s, listen=True)
            return
        try:
            await self._seated(reader, writer, seat)
        finally:
            self._room.leave(seat)

    # --- a client's session -------------------------------------------------------------

    async def _session(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter,
                       splitter: LineSplitter, lines: Lines, now_s: float) -> None:
        policy = self.policy
        client = Client(next(self._ids), writer, self.queue_limit, now_s,
                        WorkBudget(policy.lines_per_s, policy.lines_burst, now_s))
        self.clients[client.id] = client
        sender = asyncio.create_task(client.write_loop(), name=f"control-client-{client.id}")
        try:
            await self._serve_lines(lines, client)
            await self._read_lines(reader, client, splitter)
        except (ConnectionError, OSError):
            pass
        finally:
            self.clients.pop(client.id, None)
            client.close()
            self._hand_over()
            sender.cancel()
            with contextlib.suppress(asyncio.CancelledError, ConnectionError, OSError):
                await sender

    async def _read_lines(self, reader: asyncio.StreamReader, client: Client,
                          splitter: LineSplitter) -> None:
        while not client.closed:
            chunk = await reader.read(_READ_CHUNK)
            if not chunk:
                return
            lines, blank = splitter.feed(chunk)
            await self._serve_lines(lines, client, blank_units(blank))

    async def _serve_lines(self, lines: Lines, client: Client, units: float = 0.0) -> None:
        """Serve a client's requests, yielding to the loop every ``TURN_UNITS`` of work (and
        after each chunk) and reading no faster than its budget allows."""
        loop = asyncio.get_running_loop()
        for line in lines:
            await client.room_for_replies()
            if client.closed or client.gone:
                return
            if isinstance(line, TooLong):
                client.send_reply(error_line(
                    None, INVALID_REQUEST, f"line longer than {self.max_line_bytes} bytes refused"))
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

    # --- places: who holds one, who gives one up ----------------------------------------

    def _place_free(self, now_s: float) -> bool:
        """Whether a newcomer gets a place now (nobody waiting before it), making room if
        a client has been idle or stalled long enough."""
        if self._room.queued:
            return False
        return len(self.clients) + self._promised < self.max_clients or self._make_room(now_s)

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
        self.clients.pop(client.id, None)
        client.close_saying(error_line(
            None, APP_ERROR, f"connection closed: {reason} for {seconds:.1f} s and the socket "
            f"is full ({self.max_clients} clients)", {"reason": reason}))
        return True

    def _hand_over(self) -> None:
        """Give the places that are free to the connections waiting longest."""
        free = self.max_clients - len(self.clients) - self._promised
        if free > 0:
            self._promised += self._room.hand_over(free)

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
                self.clients.pop(client.id, None)
                client.close_saying(error_line(None, APP_ERROR, message, {"reason": reason}))
            self._hand_over()
            if self._refused_unlogged:
                log.warning("control.clients_refused", count=self._refused_unlogged,
                            clients=len(self.clients), max_clients=self.max_clients,
                            waiting=len(self._room))
                self._refused_unlogged = 0

    # --- past the limit ----------------------------------------------------------------

    async def _seated(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter,
                      seat: Seat) -> None:
        """In the waiting room: an ``estop`` is served at once, anything else waits for a
        place; refused when ``wait_s`` runs out."""
        splitter = LineSplitter(self.max_line_bytes)
        lines: Lines = []
        with contextlib.suppress(TimeoutError, ConnectionError, OSError):
            async with asyncio.timeout(self.policy.wait_s):
                lines = await _first_lines(reader, splitter)
        placed = (bool(lines) and _peek(lines[0])[1] != "estop"
                  and await self._wait_for_place(seat))
        self._room.leave(seat)  # it holds a place now, or it is served an estop or refused
        if placed:
            self.counts["waited"] += 1
            await self._session(reader, writer, splitter, lines, seat.since_s)
        else:
            await self._refuse(reader, writer, seat.since_s, lines[0] if lines else None)

    async def _wait_for_place(self, seat: Seat) -> bool:
        """Wait (what is left of ``wait_s``) for a place; False when none came."""
        loop = asyncio.get_running_loop()
        if len(self.clients) + self._promised < self.max_clients or self._make_room(loop.time()):
            return True
        place = self._room.queue(seat)
        left_s = seat.since_s + self.policy.wait_s - loop.time()
        try:
            await asyncio.wait_for(place, max(0.0, left_s))
        except TimeoutError:
            return False
        finally:
            if place.done() and not place.cancelled():
                self._promised -= 1  # handed over: now it is taken (or given up)
        return True

    async def _refuse(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter,
                      since_s: float, first: bytes | TooLong | None = None, *,
                      listen: bool = False) -> None:
        """No place for it: an ``estop`` is served all the same, anything else is refused
        with its id ("too many clients"); with ``listen`` (not yet heard) it is given
        ``refusal_linger_s`` to say which. Past ``lingering_max`` of these at once, a
        newcomer is told at once."""
        if self._lingering >= self.policy.lingering_max:
            self._count_refusal()
            writer.write(self._refusal(None))
            writer.close()
            return
        self._lingering += 1
        try:
            if listen:
                with contextlib.suppress(TimeoutError, ConnectionError, OSError):
                    async with asyncio.timeout(self.policy.refusal_linger_s):
                        lines = await _first_lines(reader, LineSplitter(self.max_line_bytes))
                        first = lines[0] if lines else None
            request_id, method = _peek(first)
            if method == "estop" and isinstance(first, bytes):
                reply = await self._serve_estop(first, writer, since_s)
            else:
                self._count_refusal()
                reply = [self._refusal(request_id)]
            await close_cleanly(reader, writer, reply, self.policy.refusal_linger_s)
        finally:
            self._lingering -= 1

    async def _serve_estop(self, line: bytes, writer: asyncio.StreamWriter,
                           since_s: float) -> list[bytes]:
        """An ``estop`` past the limit: served; its reply (to send before closing)."""
        loop = asyncio.get_running_loop()
        now_s = loop.time()
        client = Client(next(self._ids), writer, self.queue_limit, now_s,
                        WorkBudget(self.policy.lines_per_s, self.policy.lines_burst, now_s))
        await self._handle_line(line, client)
        self.counts["estop_past_limit"] += 1
        log.warning("control.estop_past_limit", client=client.id, clients=len(self.clients),
                    ms=round((loop.time() - since_s) * 1000, 3))
        return client.take_queued()

    def _count_refusal(self) -> None:
        self.counts["refused"] += 1
        self._refused_unlogged += 1

    def _refusal(self, request_id: Any) -> bytes:
        return error_line(request_id, APP_ERROR,
                          f"too many clients ({self.max_clients} connected); try again shortly",
                          {"reason": TOO_MANY_CLIENTS, "max_clients": self.max_clients})


async def _first_lines(reader: asyncio.StreamReader, splitter: LineSplitter) -> Lines:
    """The lines of the first chunk that completes one (none if the client closes first)."""
    while chunk := await reader.read(_READ_CHUNK):
        lines, _blank = splitter.feed(chunk)
        if lines:
            return lines
    return []


def _peek(line: bytes | TooLong | None) -> tuple[Any, str | None]:
    """The request's id and method, as far as they can be read (None, None if not)."""
    if not isinstance(line, bytes):
        return None, None
    try:
        request = parse_request(line)
    except RpcError as exc:
        return exc.request_id, None
    return (None if request.is_notification else request.id), request.method
