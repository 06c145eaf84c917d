"""The customer's page at ``/me``, phone-sized: request a pickup, follow it live, confirm
loaded and unloaded, cancel, pay; only the actions its status allows now. Every action calls
the API's own route function (the same ownership checks and services); a customer reaches
only its own requests (another's: 403)."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Path
from fastapi import Request as HttpRequest
from fastapi.responses import Response

from fleet.api import requests as requests_api
from fleet.api.deps import server_of
from fleet.api.request_reads import newest_requests, one_request
from fleet.api.schemas import RequestCreate, RequestOut
from fleet.console.html import banner, button_form, esc, page, section, when
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
from fleet.errors import FleetError, NotFound
from fleet.models import Customer
from fleet.status import ACTIVE, ALLOWED, Action, Status
from fleet.tokens import Role

router = APIRouter(route_class=ConsoleRoute, include_in_schema=False)

Id = Annotated[int, Path(ge=1, le=2**31 - 1)]
# What each status means to the customer, in words.
SAYS = {
    Status.PENDING: "Waiting for the laundry room to accept it",
    Status.ACCEPTED: "A robot is on its way to you",
    Status.ARRIVED_AT_ROOM: "The robot is at your door: load your laundry",
    Status.LAUNDRY_LOADED: "Your laundry is on its way to the laundry room",
    Status.WASHING: "Your laundry is being washed",
    Status.GOING_TO_ROOM: "Clean laundry on its way back to you",
    Status.ARRIVED_FOR_DELIVERY: "The robot is at your door: take your clean laundry",
    Status.GOING_TO_BASE: "The robot is going back",
    Status.COMPLETED: "Done, thank you",
    Status.DECLINED: "Declined by the laundry room",
    Status.CANCELLED: "Cancelled",
}
_LABELS = {Action.CONFIRM_LOADED: "I have loaded it", Action.CONFIRM_UNLOADED: "I took it",
           Action.PAY: "Pay", Action.CANCEL: "Cancel the request"}


def customer_actions(request: RequestOut) -> list[Action]:
    """The buttons for a customer's request: what its status (and the robot's scale) allow."""
    status = Status(request.Status)
    shown = []
    if request.CanConfirmLoaded:
        shown.append(Action.CONFIRM_LOADED)
    if request.CanConfirmUnloaded:
        shown.append(Action.CONFIRM_UNLOADED)
    if status in ALLOWED[Action.PAY] and not request.IsPaid:
        shown.append(Action.PAY)
    if status in ALLOWED[Action.CANCEL]:
        shown.append(Action.CANCEL)
    return shown


def _request_card(request: RequestOut, csrf: str) -> str:
    status = Status(request.Status)
    if status == Status.PENDING and request.IsApproved:
        says = "Accepted: waiting for a free robot"
    else:
        says = SAYS[status]
    buttons = "".join(
        button_form(f"/me/requests/{request.Id}/{action}", _LABELS[action], csrf,
                    css="danger" if action == Action.CANCEL else "big", name=str(action))
        for action in customer_actions(request))
    paid = '<p class="note">Paid</p>' if request.IsPaid else ""
    return (f'<article class="card" id="request-{request.Id}" '
            f'data-status="{esc(request.Status)}"><h3>Request {request.Id}</h3>'
            f'<p class="status s-{esc(request.Status)}">{esc(says)}</p>'
            f'<p class="note">{esc(request.Status)} since {esc(when(request.StatusChangedAt))}'
            f"</p>{paid}{_scale_wait(request)}<div class=\"actions\">{buttons}</div>"
            "</article>")


def _scale_wait(request: RequestOut) -> str:
    """While the robot at the door waits for its scale, no notification says when the
    confirmation becomes possible: the page asks again every 2 s (``data-refresh-ms``)."""
    status = Status(request.Status)
    if status == Status.ARRIVED_AT_ROOM and not request.CanConfirmLoaded:
        text = "Put your laundry in the robot: the button appears when its scale reads it."
    elif status == Status.ARRIVED_FOR_DELIVERY and not request.CanConfirmUnloaded:
        text = "Take your laundry out: the button appears when the robot is empty."
    else:
        return ""
    return f'<p class="note" data-refresh-ms="2000">{esc(text)}</p>'


async def _status(http: HttpRequest, login: Login) -> str:
    mine = await newest_requests(server_of(http), login.principal, limit=5)
    current = next((r for r in mine if Status(r.Status) in ACTIVE), None)
    if current is not None:
        return _request_card(current, login.csrf_token)
    last = _request_card(mine[0], login.csrf_token) if mine else ""
    return (button_form("/me/request", "Request a pickup", login.csrf_token, css="big",
                        name="request-pickup") + last)


async def _name(http: HttpRequest, login: Login) -> str:
    server = server_of(http)
    async with server.db.read() as session:
        customer = await session.get(Customer, login.principal.customer_id)
    return customer.name if customer is not None else f"customer {login.principal.subject}"


async def _me(http: HttpRequest, login: Login, message: str | None = None,
              status_code: int = 200) -> Response:
    body = banner(message) + section("mine", "/me/status", "My laundry",
                                     await _status(http, login))
    return html(page("Laundry", body, user=await _name(http, login),
                     csrf=login.csrf_token, live=True, follow="requests"), status_code)


@router.get("/me")
async def me(http: HttpRequest) -> Response:
    login = await login_of(http)
    if login is None:
        return see_other("/login")
    check_role(login, Role.CUSTOMER)
    return await _me(http, login)


@router.get("/me/status")
async def status(http: HttpRequest) -> Response:
    return html(await _status(http, await require_login(http, Role.CUSTOMER)))


@router.get("/me/requests/{request_id}")
async def one(request_id: Id, http: HttpRequest) -> Response:
    login = await require_login(http, Role.CUSTOMER)
    request = await one_request(server_of(http), login.principal, request_id)
    return html(page("Laundry", _request_card(request, login.csrf_token),
                     user=await _name(http, login), csrf=login.csrf_token))


@router.post("/me/request")
async def request_pickup(http: HttpRequest) -> Response:
    login, _form = await checked_form(http, Role.CUSTOMER)
    customer_id = login.principal.customer_id
    assert customer_id is not None  # a customer login
    try:
        await requests_api.create(RequestCreate(CustomerId=customer_id), http,
                                  login.principal)
    except FleetError as exc:
        return await _me(http, login, exc.message, exc.status_code)
    return see_other("/me")


@router.post("/me/requests/{request_id}/{action}")
async def request_action(request_id: Id, action: str, http: HttpRequest) -> Response:
    login, _form = await checked_form(http, Role.CUSTOMER)
    if action not in _LABELS:
        msg = f"no such action: {action}"
        raise NotFound(msg)
    try:
        await requests_api.act(request_id, Action(action), http, login.principal)
    except FleetError as exc:
        if exc.status_code in (403, 404):
            raise
        return await _me(http, login, exc.message, exc.status_code)
    return see_other("/me")
