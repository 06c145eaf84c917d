"""Logging in and out of the console: a bearer token exchanged for a session cookie.

``GET /login`` shows the form; ``POST /login`` checks the token as the API does (the same
failure limit per client address, 429 beyond it) and opens a session: cookie ``HttpOnly``,
``SameSite=Strict``, ``Secure`` when the request came over TLS. The login form itself carries
a CSRF token bound to a short-lived cookie (double submit), so another site cannot log a
browser in under its own token. ``POST /logout`` revokes the session in the database.
"""

from __future__ import annotations

import secrets

from fastapi import APIRouter
from fastapi import Request as HttpRequest
from fastapi.responses import Response

from fleet.api.deps import server_of
from fleet.console.html import login_page
from fleet.console.sessions import (
    COOKIE,
    SESSION_TTL_S,
    may_log_in,
    open_session,
    revoke_session,
)
from fleet.console.web import (
    ConsoleRoute,
    checked_form,
    html,
    login_of,
    read_form,
    see_other,
    session_id_of,
)
from fleet.errors import TooManyFailures
from fleet.tokens import MAX_TOKEN_CHARS, Role

router = APIRouter(route_class=ConsoleRoute, include_in_schema=False)

LOGIN_CSRF_COOKIE = "fleet_login_csrf"
LOGIN_FORM_TTL_S = 3600


def home_of(role: Role) -> str:
    return "/" if role == Role.ADMIN else "/me"


def _cookie(response: Response, http: HttpRequest, name: str, value: str, max_age_s: int,
            path: str = "/") -> None:
    response.set_cookie(name, value, max_age=max_age_s, path=path, httponly=True,
                        samesite="strict", secure=http.url.scheme == "https")


def _login_form(http: HttpRequest, message: str | None = None,
                status_code: int = 200) -> Response:
    form_csrf = secrets.token_urlsafe(32)
    response = html(login_page(form_csrf, message), status_code)
    _cookie(response, http, LOGIN_CSRF_COOKIE, form_csrf, LOGIN_FORM_TTL_S, path="/login")
    return response


@router.get("/login")
async def login_form(http: HttpRequest) -> Response:
    login = await login_of(http)
    if login is not None:
        return see_other(home_of(login.principal.role))
    return _login_form(http)


@router.post("/login")
async def log_in(http: HttpRequest) -> Response:
    server = server_of(http)
    client = http.client.host if http.client else "unknown"
    retry_after_s = server.auth.limiter.retry_after_s(client)
    if retry_after_s:
        msg = f"too many failed logins from this address; retry in {retry_after_s} s"
        raise TooManyFailures(msg)
    form = await read_form(http)
    sent, expected = form.get("csrf", ""), http.cookies.get(LOGIN_CSRF_COOKIE, "")
    if not expected or not secrets.compare_digest(sent.encode(), expected.encode()):
        return _login_form(http, "The login form expired; please try again.", 403)
    token = form.get("token", "").strip()
    principal = None
    if token and len(token) <= MAX_TOKEN_CHARS and token.isascii():
        principal = await server.auth.principal(token)
    if principal is None:
        server.auth.limiter.failed(client)
        return _login_form(http, "That token is unknown or revoked.", 401)
    if not may_log_in(principal):
        return _login_form(http, "A robot's token cannot log in to the console.", 403)
    async with server.db.write() as session:
        session_id, _login = await open_session(session, server.clock(), principal)
    response = see_other(home_of(principal.role))
    _cookie(response, http, COOKIE, session_id, SESSION_TTL_S)
    response.delete_cookie(LOGIN_CSRF_COOKIE, path="/login")
    return response


@router.post("/logout")
async def log_out(http: HttpRequest) -> Response:
    await checked_form(http, None)
    server = server_of(http)
    session_id = session_id_of(http.headers.get("cookie"))
    if session_id is not None:
        async with server.db.write() as session:
            await revoke_session(session, server.clock(), session_id)
    response = see_other("/login")
    response.delete_cookie(COOKIE, path="/", httponly=True, samesite="strict",
                           secure=http.url.scheme == "https")
    return response
