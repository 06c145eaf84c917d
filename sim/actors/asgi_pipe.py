"""The simulator's wire between HTTP clients and the in-process fleet app.

``AsgiPipe`` is an ``httpx.AsyncBaseTransport``, like ``httpx.ASGITransport``: the robots' and
the actors' real ``httpx.AsyncClient`` build, authenticate and read their requests as over a
network, and the fleet app gets the same ASGI scope (method, headers, path, raw path, query
string, server, client, root path). It is plumbing, like the byte pipe of a serial port: it
does what a socket and an HTTP server would, in fewer steps than ``httpx.ASGITransport``, which
every request of a laundry run goes through (each robot's data exchange, each customer's poll
and the staff's, each second). The request body is handed over in one message; the app runs on
the caller's task; an exception in the app is raised to the caller.
"""

from __future__ import annotations

import asyncio
from typing import Any

import httpx
from starlette.types import ASGIApp, Message

ASGI = {"version": "3.0"}
# What httpx.ASGITransport tells the app about the client by default.
CLIENT = ("127.0.0.1", 123)


class AsgiPipe(httpx.AsyncBaseTransport):
    """Args:
        app: the ASGI application.
        client: the client address the app sees (``scope["client"]``).
    """

    def __init__(self, app: ASGIApp, client: tuple[str, int] = CLIENT) -> None:
        self.app = app
        self.client = client

    async def handle_async_request(self, request: httpx.Request) -> httpx.Response:
        url = request.url
        scope: dict[str, Any] = {
            "type": "http", "asgi": ASGI, "http_version": "1.1",
            "method": request.method,
            "headers": [(k.lower(), v) for k, v in request.headers.raw],
            "scheme": url.scheme, "path": url.path,
            "raw_path": url.raw_path.partition(b"?")[0], "query_string": url.query,
            "server": (url.host, url.port), "client": self.client, "root_path": "",
        }
        exchange = _Exchange(await request.aread(), head=request.method == "HEAD")
        await self.app(scope, exchange.receive, exchange.send)
        if exchange.status is None or not exchange.complete:
            msg = f"the app did not complete its answer to {request.method} {url.path}"
            raise RuntimeError(msg)
        return httpx.Response(exchange.status, headers=exchange.headers,
                              stream=httpx.ByteStream(b"".join(exchange.body)))


class _Exchange:
    """One request's ``receive`` and ``send``: the body once, then (as a server would while
    the answer is written) nothing until the answer is complete, then ``http.disconnect``."""

    def __init__(self, body: bytes, *, head: bool) -> None:
        self._request: Message | None = {"type": "http.request", "body": body,
                                         "more_body": False}
        self._head = head
        self.status: int | None = None
        self.headers: list[tuple[bytes, bytes]] = []
        self.body: list[bytes] = []
        self.complete = False
        # Made only if the app waits for a disconnect before its answer is complete.
        self._completed: asyncio.Future[None] | None = None

    async def receive(self) -> Message:
        request = self._request
        if request is not None:
            self._request = None
            return request
        if not self.complete:
            if self._completed is None:
                self._completed = asyncio.get_running_loop().create_future()
            await asyncio.shield(self._completed)
        return {"type": "http.disconnect"}

    async def send(self, message: Message) -> None:
        if message["type"] == "http.response.start":
            if self.status is not None:
                msg = "the app started its answer twice"
                raise RuntimeError(msg)
            self.status = int(message["status"])
            self.headers = list(message.get("headers", []))
        elif message["type"] == "http.response.body":
            if self.complete:
                msg = "the app sent body after its answer was complete"
                raise RuntimeError(msg)
            body = message.get("body", b"")
            if body and not self._head:
                self.body.append(body)
            if not message.get("more_body", False):
                self.complete = True
                if self._completed is not None:
                    self._completed.set_result(None)
