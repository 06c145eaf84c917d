"""Customers' and the laundry staff's request reads answered in front of FastAPI.

A customer's app polls its request (``GET /api/requests/{id}``) and the staff's page the list
(``GET /api/requests``), each about once a second. FastAPI's routing, dependency solving and
response validation cost more than the read itself. ``RequestsFastPath`` is an ASGI middleware
that answers the plain forms of both with what the routes do: the same reads
(``fleet.api.request_reads``), the same serialisation (pydantic's JSON of ``RequestOut``, by
alias, as FastAPI's response field dumps it), the same headers, and the same error bodies for
404 and 403. Everything else goes on to the FastAPI app unchanged: other methods and paths, any
query string, an id that is not plain decimal digits in the route's range, a caller that is
neither a customer nor an admin (the route's 403), a scope with a root path.
"""

from __future__ import annotations

import re

from pydantic import TypeAdapter
from starlette.types import ASGIApp, Receive, Scope, Send

from fleet.api.auth import SCOPE_KEY
from fleet.api.request_reads import newest_requests, one_request
from fleet.api.robot import encoded_error
from fleet.api.schemas import RequestOut
from fleet.errors import FleetError
from fleet.server import FleetServer
from fleet.tokens import Principal, Role

LIST_PATH = "/api/requests"
ONE_PREFIX = LIST_PATH + "/"
# The route's RequestId: an int in 1..2**31-1. Only plain digits without a leading zero are
# taken here; other spellings the route may also read (" 7", "+7", "007") go to the route.
_ID = re.compile(r"[1-9][0-9]{0,9}")
MAX_ID = 2**31 - 1
_READERS = frozenset({Role.ADMIN, Role.CUSTOMER})
_JSON = b"application/json"
# What FastAPI dumps for ``response_model=RequestOut`` / ``list[RequestOut]`` (by alias).
_ONE = TypeAdapter(RequestOut)
_LIST = TypeAdapter(list[RequestOut])


class RequestsFastPath:
    """ASGI middleware: answers ``GET /api/requests`` (no query) and ``GET /api/requests/{id}``
    for a customer or admin caller; passes everything else on. ``FleetApp`` puts it in front of
    FastAPI's own middleware."""

    def __init__(self, app: ASGIApp, server: FleetServer) -> None:
        self.app = app
        self.server = server

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        caller = _reader(scope)
        if caller is None:
            await self.app(scope, receive, send)
            return
        path: str = scope["path"]
        if path == LIST_PATH:
            reply, status = await self._list(caller)
        elif path.startswith(ONE_PREFIX) and (request_id := _request_id(path)) is not None:
            reply, status = await self._one(caller, request_id)
        else:
            await self.app(scope, receive, send)
            return
        await send({"type": "http.response.start", "status": status, "headers": [
            (b"content-length", str(len(reply)).encode()), (b"content-type", _JSON)]})
        await send({"type": "http.response.body", "body": reply})

    async def _list(self, caller: Principal) -> tuple[bytes, int]:
        try:
            return _LIST.dump_json(await newest_requests(self.server, caller),
                                   by_alias=True), 200
        except FleetError as exc:
            return encoded_error(exc), exc.status_code

    async def _one(self, caller: Principal, request_id: int) -> tuple[bytes, int]:
        try:
            return _ONE.dump_json(await one_request(self.server, caller, request_id),
                                  by_alias=True), 200
        except FleetError as exc:
            return encoded_error(exc), exc.status_code


def _reader(scope: Scope) -> Principal | None:
    """The caller, when this is a request read the fast path may answer by its method, query
    string, root path and caller (the path is looked at after)."""
    if scope["type"] != "http" or scope["method"] != "GET" or scope.get("root_path") \
            or scope.get("query_string"):
        return None
    principal = scope.get(SCOPE_KEY)
    if not isinstance(principal, Principal) or principal.role not in _READERS:
        return None
    return principal


def _request_id(path: str) -> int | None:
    """The id of ``/api/requests/{id}`` in its plain spelling, in the route's range."""
    text = path[len(ONE_PREFIX):]
    if _ID.fullmatch(text) is None:
        return None
    request_id = int(text)
    return request_id if request_id <= MAX_ID else None
