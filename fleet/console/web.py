"""What every console route needs: who is logged in, the posted form, CSRF, answers.

Pages (``GET /``, ``GET /me``) send a browser without a session to the login page (303);
fragments and form posts under ``/console/`` and ``/me/`` answer 401. A form whose CSRF token
is missing or wrong is refused with 403 before anything is done.
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable, Coroutine
from http.cookies import CookieError, SimpleCookie
from typing import Any
from urllib.parse import parse_qs

import structlog
from fastapi import Request as HttpRequest
from fastapi.responses import HTMLResponse, RedirectResponse, Response
from fastapi.routing import APIRoute
from starlette.types import Scope

from fleet.api.deps import server_of
from fleet.console.html import error_page
from fleet.console.sessions import COOKIE, Login, csrf_ok, find_session
from fleet.errors import FleetError, Forbidden, Unauthorized
from fleet.server import FleetServer
from fleet.tokens import Principal, Role

log = structlog.get_logger(__name__)

FORM_TYPE = "application/x-www-form-urlencoded"
MAX_FORM_FIELDS = 40
"""The settings form has the most (one a setting and its CSRF token)."""
# Every console answer: scripts and styles from this server only (no CDN, no inline
# script), never framed by another site.
SECURITY_HEADERS = {
    "Content-Security-Policy": ("default-src 'self'; img-src 'self' data:; "
                                "frame-ancestors 'none'; form-action 'self'"),
    "X-Frame-Options": "DENY", "X-Content-Type-Options": "nosniff",
    "Referrer-Policy": "same-origin", "Cache-Control": "no-store",
}


def session_id_of(cookie_header: str | None) -> str | None:
    """The session id of a ``Cookie`` header, or None."""
    if not cookie_header:
        return None
    try:
        jar: SimpleCookie = SimpleCookie(cookie_header)
    except CookieError:
        return None
    morsel = jar.get(COOKIE)
    return morsel.value if morsel is not None else None


async def login_of(http: HttpRequest) -> Login | None:
    """The login of the request's session cookie, or None."""
    session_id = session_id_of(http.headers.get("cookie"))
    if session_id is None:
        return None
    server = server_of(http)
    async with server.db.read() as session:
        return await find_session(session, server.clock(), session_id)


async def require_login(http: HttpRequest, role: Role | None) -> Login:
    """The login of a fragment or form post: 401 without a session, 403 for another role
    (``role`` None: either)."""
    login = await login_of(http)
    if login is None:
        msg = "log in first (no console session)"
        raise Unauthorized(msg)
    if role is not None:
        check_role(login, role)
    return login


def check_role(login: Login, role: Role) -> None:
    if login.principal.role != role:
        where = "the staff console" if role == Role.ADMIN else "the customer page"
        msg = f"{where} is not for a {login.principal.role} login"
        raise Forbidden(msg)


async def read_form(http: HttpRequest) -> dict[str, str]:
    """A posted urlencoded form (first value of each field; anything else: empty)."""
    content_type = http.headers.get("content-type", "").split(";")[0].strip().lower()
    if content_type != FORM_TYPE:
        return {}
    body = (await http.body()).decode("utf-8", "replace")
    try:
        fields = parse_qs(body, max_num_fields=MAX_FORM_FIELDS)
    except ValueError:  # more fields than any console form has: nothing of it is read
        return {}
    return {key: values[0] for key, values in fields.items()}


async def checked_form(http: HttpRequest, role: Role | None) -> tuple[Login, dict[str, str]]:
    """The login and form of a state-changing post: 401, 403 (role), 403 (CSRF)."""
    login = await require_login(http, role)
    form = await read_form(http)
    if not csrf_ok(login, form.get("csrf")):
        msg = "the form's CSRF token is missing or wrong; reload the page"
        raise Forbidden(msg)
    return login, form


def html(body: str, status_code: int = 200) -> HTMLResponse:
    return HTMLResponse(body, status_code=status_code, headers=SECURITY_HEADERS)


def see_other(url: str) -> Response:
    """303: the browser GETs ``url`` (after a form post, or to the login page)."""
    return RedirectResponse(url, status_code=303, headers=SECURITY_HEADERS)


class ConsoleRoute(APIRoute):
    """A console route: a refusal (``FleetError``: 401, 403, 404, 409...) is a small HTML
    page with the message for a person, not the API's JSON."""

    def get_route_handler(self) -> Callable[[HttpRequest], Coroutine[Any, Any, Response]]:
        handler = super().get_route_handler()

        async def handle(http: HttpRequest) -> Response:
            try:
                return await handler(http)
            except FleetError as exc:
                log.info("fleet.console.refused", path=http.url.path,
                         status=exc.status_code, reason=exc.message)
                return html(error_page(exc.status_code, exc.message), exc.status_code)

        return handle


# The console's pages and forms: they answer a browser without a session themselves (the
# login page, 401), so the API's bearer-token middleware lets them through.
CONSOLE_PATHS = frozenset({"/", "/login", "/logout", "/me", "/site", "/settings"})
CONSOLE_PREFIXES = ("/console/", "/me/", "/static/", "/robots/")


def is_console_path(path: str) -> bool:
    return path in CONSOLE_PATHS or path.startswith(CONSOLE_PREFIXES)


def cookie_caller(server: FleetServer) -> Callable[[Scope], Awaitable[Principal | None]]:
    """Who a request's session cookie speaks for (``GET /api/events`` from a console page)."""

    async def caller(scope: Scope) -> Principal | None:
        cookies = [v.decode("latin-1") for k, v in scope["headers"] if k == b"cookie"]
        session_id = session_id_of("; ".join(cookies))
        if session_id is None:
            return None
        async with server.db.read() as session:
            login = await find_session(session, server.clock(), session_id)
        return login.principal if login is not None else None

    return caller
