"""The robots' data exchange answered in front of FastAPI's request machinery.

Every robot posts once a second. Profiled at 500 robots, FastAPI's routing, dependency solving,
body handling and response wrapping cost several times the exchange itself. ``ExchangeFastPath``
is an ASGI middleware that answers a well-formed data exchange directly, with what the route
does: the same pydantic model (read by pydantic's JSON parser), the same service call
(``robot.answer``) and the same reply bytes. Anything else goes on to the FastAPI app
unchanged, with the body replayed: other paths, a robot name the route's path rules refuse, a
caller that is not that robot (``fleet.api.auth.Authenticate``, in front, has checked the
token), a body that is not ``application/json``, does not parse or does not validate. So bad
input keeps the route's 4xx answers, and the route stays in the OpenAPI document.
"""

from __future__ import annotations

import re
from collections.abc import Awaitable, Callable

from pydantic import ValidationError
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from fleet.api.auth import SCOPE_KEY
from fleet.api.robot import answer, encoded_error
from fleet.api.schemas import DataExchangeIn
from fleet.errors import FleetError
from fleet.server import FleetServer
from fleet.tokens import Principal

PREFIX = "/api/Robot/"
SUFFIX = "/data-exchange"
# The route's path rules for RobotName (1..100 characters, no control characters), and no "/"
# (a path segment).
_NAME = re.compile(r"[^/\x00-\x1f\x7f]{1,100}")
# Larger bodies (a real report is a few hundred bytes) are left to the route.
MAX_BODY_BYTES = 256 * 1024
_JSON = b"application/json"


class ExchangeFastPath:
    """ASGI middleware: answers ``POST /api/Robot/{RobotName}/data-exchange`` when the request
    is well formed; passes everything else on. ``FleetApp`` puts it in front of FastAPI's own
    middleware."""

    def __init__(self, app: ASGIApp, server: FleetServer) -> None:
        self.app = app
        self.server = server

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        name = _robot_name(scope)
        principal = scope.get(SCOPE_KEY) if name is not None else None
        if name is None or not isinstance(principal, Principal) or not principal.is_robot(name):
            await self.app(scope, receive, send)
            return
        messages, body = await _read_body(receive)
        parsed = _parse(body) if body is not None else None
        if parsed is None:
            await self.app(scope, _replay(messages, receive), send)
            return
        try:
            reply, status = await answer(self.server, name, parsed), 200
        except FleetError as exc:
            reply, status = encoded_error(exc), exc.status_code
        await send({"type": "http.response.start", "status": status, "headers": [
            (b"content-length", str(len(reply)).encode()), (b"content-type", _JSON)]})
        await send({"type": "http.response.body", "body": reply})


def _robot_name(scope: Scope) -> str | None:
    """The robot's name when this is a data exchange the fast path may answer."""
    if scope["type"] != "http" or scope["method"] != "POST" or scope.get("root_path"):
        return None
    path: str = scope["path"]
    if not (path.startswith(PREFIX) and path.endswith(SUFFIX)):
        return None
    name = path[len(PREFIX):-len(SUFFIX)]
    if _NAME.fullmatch(name) is None:
        return None
    for key, value in scope["headers"]:
        if key == b"content-type":
            return name if value.partition(b";")[0].strip().lower() == _JSON else None
    return None


async def _read_body(receive: Receive) -> tuple[list[Message], bytes | None]:
    """The messages received, and the whole body (None: too large, or not a plain body)."""
    messages: list[Message] = []
    size = 0
    while True:
        message = await receive()
        messages.append(message)
        if message["type"] != "http.request":
            return messages, None
        size += len(message.get("body", b""))
        if size > MAX_BODY_BYTES:
            return messages, None
        if not message.get("more_body", False):
            break
    if len(messages) == 1:
        return messages, messages[0].get("body", b"")
    return messages, b"".join(m.get("body", b"") for m in messages)


def _parse(body: bytes) -> DataExchangeIn | None:
    """The body parsed and validated in one pass of pydantic's JSON parser, or None (the route
    then reads it with ``json.loads`` and the same model, and words the error)."""
    if not body:
        return None
    try:
        return DataExchangeIn.model_validate_json(body)
    except ValidationError:
        return None


def _replay(messages: list[Message], receive: Receive) -> Callable[[], Awaitable[Message]]:
    pending = list(messages)

    async def replayed() -> Message:
        if pending:
            return pending.pop(0)
        return await receive()

    return replayed
