"""A cap on request bodies: 413 with a message instead of reading megabytes into memory.

The largest legitimate body is a data exchange listing every beacon a robot hears (a few
hundred bytes each); 1 MiB leaves room for a site with thousands. A body announced larger by
its Content-Length is refused before it is read; a chunked one is refused as soon as it
passes the cap, if no answer has been started yet.
"""

from __future__ import annotations

import json

from starlette.exceptions import HTTPException
from starlette.types import ASGIApp, Message, Receive, Scope, Send

MAX_BODY_BYTES = 1024 * 1024


class BodyTooLarge(HTTPException):
    """Raised while the body is read. An HTTPException, so that FastAPI's body parsing (which
    turns other errors into 400) passes it on and answers 413 itself."""

    def __init__(self, size: int, max_bytes: int) -> None:
        super().__init__(413, f"request body of {size} bytes is over the {max_bytes} byte limit")


class BodyLimit:
    """ASGI middleware refusing request bodies over ``max_bytes`` with 413."""

    def __init__(self, app: ASGIApp, max_bytes: int = MAX_BODY_BYTES) -> None:
        self.app = app
        self.max_bytes = max_bytes

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        for key, value in scope["headers"]:
            if key == b"content-length":
                try:
                    declared = int(value)
                except ValueError:
                    declared = 0  # the HTTP parser refuses a malformed length itself
                if declared > self.max_bytes:
                    await self._refuse(send, BodyTooLarge(declared, self.max_bytes))
                    return
                break
        received = 0
        started = False

        async def counted_receive() -> Message:
            nonlocal received
            message = await receive()
            if message["type"] == "http.request":
                received += len(message.get("body", b""))
                if received > self.max_bytes:
                    raise BodyTooLarge(received, self.max_bytes)
            return message

        async def tracked_send(message: Message) -> None:
            nonlocal started
            started = started or message["type"] == "http.response.start"
            await send(message)

        try:
            await self.app(scope, counted_receive, tracked_send)
        except BodyTooLarge as exc:
            if started:
                raise
            await self._refuse(send, exc)

    async def _refuse(self, send: Send, exc: BodyTooLarge) -> None:
        body = json.dumps({"detail": exc.detail}).encode()
        await send({"type": "http.response.start", "status": 413, "headers": [
            (b"content-type", b"application/json"),
            (b"content-length", str(len(body)).encode()), (b"connection", b"close")]})
        await send({"type": "http.response.body", "body": body})
