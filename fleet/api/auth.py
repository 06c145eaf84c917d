"""Authentication in front of everything, authorisation per route.

``Authenticate`` (ASGI middleware, before the data-exchange fast path and before FastAPI reads
a body) answers 401 for a missing, malformed, unknown or revoked bearer token and 429 for a
client that failed too often, and puts the caller's ``Principal`` in the scope. The routes
declare ``Security(bearer)`` (so the scheme is in the OpenAPI document) through the
dependencies below, which answer 403 for a caller of the wrong role or owner. Both happen
before a route does any work, so a refused call never changes anything. The console's pages
(``fleet.console``) check their own session cookie; of the API, only the event stream also
takes that cookie, so that a console page can follow it.
"""

from __future__ import annotations

import json
from collections.abc import Awaitable, Callable
from typing import Annotated

import structlog
from fastapi import Depends, Security
from fastapi import Request as HttpRequest
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer
from starlette.types import ASGIApp, Receive, Scope, Send

from fleet.api.docs import ASSETS_URL
from fleet.auth import Authenticator
from fleet.errors import Forbidden, Unauthorized
from fleet.tokens import MAX_TOKEN_CHARS, Principal, Role

log = structlog.get_logger(__name__)

SCOPE_KEY = "fleet.principal"
# Paths anyone may read: the liveness probe and the API's own documentation.
PUBLIC_PATHS = frozenset({"/health", "/openapi.json", "/docs", "/docs/oauth2-redirect",
                          "/redoc"})

bearer = HTTPBearer(
    auto_error=False, scheme_name="BearerToken",
    description="A token from `robotd-fleet token create` (robot, customer or admin).")


# Called with a request's scope: the caller its session cookie speaks for, or None.
CookieCaller = Callable[[Scope], Awaitable[Principal | None]]
# The API paths a browser's session cookie may authenticate (issue 29): the event stream
# only, which changes nothing; every call that changes something needs the bearer token.
COOKIE_PATHS = frozenset({"/api/events"})


class Authenticate:
    """ASGI middleware: 401/429 for callers without a valid token; sets ``scope[SCOPE_KEY]``.

    Args:
        app: the application behind.
        authenticator: the bearer tokens.
        own_auth: paths that authenticate on their own (the console's pages, which answer a
            browser without a session with the login page).
        cookie_caller: the caller of a session cookie, for ``COOKIE_PATHS`` called without
            an Authorization header.
    """

    def __init__(self, app: ASGIApp, authenticator: Authenticator, *,
                 own_auth: Callable[[str], bool] = lambda _path: False,
                 cookie_caller: CookieCaller | None = None) -> None:
        self.app = app
        self.auth = authenticator
        self.own_auth = own_auth
        self.cookie_caller = cookie_caller

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http" or scope["path"] in PUBLIC_PATHS \
                or scope["path"].startswith(ASSETS_URL + "/") or self.own_auth(scope["path"]):
            await self.app(scope, receive, send)
            return
        client = scope.get("client")
        address = str(client[0]) if client else "unknown"
        retry_after_s = self.auth.limiter.retry_after_s(address)
        if retry_after_s:
            await _refuse(send, 429, "too many failed authentications from this address; "
                          f"retry in {retry_after_s} s", [(b"retry-after",
                                                          str(retry_after_s).encode())])
            return
        token, problem = _bearer_token(scope)
        principal = None
        if token is not None:
            principal = await self.auth.principal(token)
        elif self.cookie_caller is not None and scope["path"] in COOKIE_PATHS \
                and _has_header(scope, b"cookie"):
            principal = await self.cookie_caller(scope)
            problem = None if principal is not None else "the console session is unknown " \
                "or expired (log in again), and there is no bearer token"
        if principal is None:
            self.auth.limiter.failed(address)
            problem = problem or "the bearer token is unknown or revoked"
            log.info("fleet.auth.refused", client=address, path=scope["path"], reason=problem)
            await _refuse(send, 401, problem, [(b"www-authenticate", b'Bearer realm="fleet"')])
            return
        scope[SCOPE_KEY] = principal
        await self.app(scope, receive, send)


def _has_header(scope: Scope, name: bytes) -> bool:
    return any(k == name for k, _v in scope["headers"])


def _bearer_token(scope: Scope) -> tuple[str | None, str | None]:
    """The token of the Authorization header, or None and why not."""
    values = [v for k, v in scope["headers"] if k == b"authorization"]
    if not values:
        return None, "an Authorization: Bearer token is required"
    if len(values) > 1:
        return None, "more than one Authorization header"
    scheme, _, token = values[0].partition(b" ")
    token = token.strip()
    if scheme.lower() != b"bearer" or not token:
        return None, "the Authorization header must be 'Bearer <token>'"
    if len(token) > MAX_TOKEN_CHARS:
        return None, "the bearer token is too long"
    try:
        return token.decode("ascii"), None
    except UnicodeDecodeError:
        return None, "the bearer token must be ASCII"


async def _refuse(send: Send, status: int, message: str,
                  headers: list[tuple[bytes, bytes]]) -> None:
    body = json.dumps({"detail": message}).encode()
    await send({"type": "http.response.start", "status": status, "headers": [
        (b"content-type", b"application/json"), (b"content-length", str(len(body)).encode()),
        *headers]})
    await send({"type": "http.response.body", "body": body})


async def caller(
    http: HttpRequest,
    _credentials: Annotated[HTTPAuthorizationCredentials | None, Security(bearer)],
) -> Principal:
    """The authenticated caller (``Authenticate`` already refused everyone else)."""
    principal = http.scope.get(SCOPE_KEY)
    if not isinstance(principal, Principal):
        msg = "an Authorization: Bearer token is required"
        raise Unauthorized(msg)
    return principal


Caller = Annotated[Principal, Depends(caller)]


async def admin(principal: Caller) -> Principal:
    if principal.role != Role.ADMIN:
        msg = f"this needs an admin token, not a {principal.role} token"
        raise Forbidden(msg)
    return principal


async def customer_or_admin(principal: Caller) -> Principal:
    if principal.role not in (Role.ADMIN, Role.CUSTOMER):
        msg = f"this needs a customer or admin token, not a {principal.role} token"
        raise Forbidden(msg)
    return principal


Admin = Annotated[Principal, Depends(admin)]
CustomerOrAdmin = Annotated[Principal, Depends(customer_or_admin)]


def check_customer(principal: Principal, customer_id: int, what: str) -> None:
    """403 unless an admin, or the customer ``customer_id`` itself, is calling."""
    if principal.role == Role.ADMIN or principal.is_customer(customer_id):
        return
    msg = f"{what} belongs to another customer"
    raise Forbidden(msg)
