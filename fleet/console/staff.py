"""The staff console at ``/``: the request board, the robots and the open alerts, with the
staff's actions as forms. Every action calls the API's own route function (the same checks,
transaction and services as ``POST /api/requests/{id}/{action}`` and the alert calls), then
sends the browser back to ``/``; a refusal (409 and the like) shows the page with the reason.
"""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Path
from fastapi import Request as HttpRequest
from fastapi.responses import Response
from sqlalchemy import select

from fleet.api import admin as admin_api
from fleet.api import alerts as alerts_api
from fleet.api import requests as requests_api
from fleet.api.deps import server_of
from fleet.api.request_reads import newest_requests
from fleet.api.schemas import AlertResolve
from fleet.console import staff_pages
from fleet.console.html import banner, page, section
from fleet.console.sessions import Login
from fleet.console.web import (
    ConsoleRoute,
    check_role,
    checked_form,
    html,
    login_of,
    require_login,
    see_other,
)
from fleet.errors import FleetError, Invalid, NotFound
from fleet.models import Customer
from fleet.status import Action
from fleet.tokens import Role

router = APIRouter(route_class=ConsoleRoute, include_in_schema=False)

BOARD_LIMIT = 200
Id = Annotated[int, Path(ge=1, le=2**31 - 1)]


async def _board(http: HttpRequest, login: Login) -> str:
    server = server_of(http)
    requests = await newest_requests(server, login.principal, limit=BOARD_LIMIT)
    async with server.db.read() as session:
        customers = {cid: name for cid, name in await session.execute(
            select(Customer.id, Customer.name))}
    return staff_pages.board(requests, customers, login.csrf_token)


async def _robots(http: HttpRequest) -> str:
    return staff_pages.robots(await admin_api.list_robots(http))


async def _alerts(http: HttpRequest, login: Login) -> str:
    open_alerts = await alerts_api.list_alerts(http, open_only=True, request_id=None,
                                               robot=None, limit=100)
    return staff_pages.alerts(open_alerts, login.csrf_token)


async def _console(http: HttpRequest, login: Login, message: str | None = None,
                   status_code: int = 200) -> Response:
    body = (banner(message)
            + section("board", "/console/board", "Requests", await _board(http, login))
            + section("alerts", "/console/alerts", "Open alerts", await _alerts(http, login))
            + section("robots", "/console/robots", "Robots", await _robots(http)))
    return html(page("Site console - requests", body, user=login.principal.subject,
                     csrf=login.csrf_token, live=True, staff=True), status_code)


@router.get("/")
async def console(http: HttpRequest) -> Response:
    login = await login_of(http)
    if login is None:
        return see_other("/login")
    check_role(login, Role.ADMIN)
    return await _console(http, login)


@router.get("/console/board")
async def board(http: HttpRequest) -> Response:
    return html(await _board(http, await require_login(http, Role.ADMIN)))


@router.get("/console/robots")
async def robots(http: HttpRequest) -> Response:
    await require_login(http, Role.ADMIN)
    return html(await _robots(http))


@router.get("/console/alerts")
async def alerts(http: HttpRequest) -> Response:
    return html(await _alerts(http, await require_login(http, Role.ADMIN)))


@router.post("/console/requests/{request_id}/{action}")
async def request_action(request_id: Id, action: str, http: HttpRequest) -> Response:
    login, _form = await checked_form(http, Role.ADMIN)
    if action not in staff_pages.BOARD_ACTIONS:
        msg = f"no such action on the board: {action}"
        raise NotFound(msg)
    try:
        await requests_api.act(request_id, Action(action), http, login.principal)
    except FleetError as exc:
        return await _console(http, login, exc.message, exc.status_code)
    return see_other("/")


@router.post("/console/alerts/{alert_id}/acknowledge")
async def acknowledge(alert_id: Id, http: HttpRequest) -> Response:
    login, _form = await checked_form(http, Role.ADMIN)
    try:
        await alerts_api.acknowledge(alert_id, http, login.principal)
    except FleetError as exc:
        return await _console(http, login, exc.message, exc.status_code)
    return see_other("/")


@router.post("/console/alerts/{alert_id}/resolve")
async def resolve(alert_id: Id, http: HttpRequest) -> Response:
    login, form = await checked_form(http, Role.ADMIN)
    laundry_at = form.get("LaundryAt") or None
    try:
        if laundry_at not in (None, "robot", "base", "customer"):
            msg = f"LaundryAt: {laundry_at!r} is not robot, base or customer"
            raise Invalid(msg)
        body = AlertResolve.model_validate({"LaundryAt": laundry_at})
        await alerts_api.resolve(alert_id, http, login.principal, body)
    except FleetError as exc:
        return await _console(http, login, exc.message, exc.status_code)
    return see_other("/")
