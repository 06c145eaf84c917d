"""A robot's console page at ``/robots/{name}``: its view now, the staff's orders (e-stop,
resume, maintenance, as CSRF forms), and what the server knows of its past: the
notifications about it (its faults, offline, e-stop and the like, newest first), its alerts
and the requests it served. The server keeps no history of a robot's state paths: the
robot's own ``robotctl events`` has those.
"""

from __future__ import annotations

from typing import Annotated
from urllib.parse import quote

from fastapi import APIRouter, Path
from fastapi import Request as HttpRequest
from fastapi.responses import Response
from sqlalchemy import select

from fleet.api.deps import server_of
from fleet.console.html import banner, button_form, esc, page, section, when
from fleet.console.robot_actions import ACTIONS, act_on_robot, allowed
from fleet.console.robot_views import RobotView, robot_views
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
from fleet.models import Alert, Notification, Request, Robot
from fleet.tokens import Role

router = APIRouter(route_class=ConsoleRoute, include_in_schema=False)

Name = Annotated[str, Path(min_length=1, max_length=100, pattern=r"^[^\x00-\x1f\x7f]+$")]
HISTORY = 30


def _url(name: str) -> str:
    return f"/robots/{quote(name, safe='')}"


async def _view(http: HttpRequest, name: str) -> tuple[RobotView, Robot]:
    server = server_of(http)
    await server.flush_pings()
    async with server.db.read() as session:
        robot = (await session.execute(
            select(Robot).where(Robot.name == name))).scalar_one_or_none()
        if robot is None:
            msg = f"robot {name!r} is not registered"
            raise NotFound(msg)
        views = await robot_views(session, server.clock())
    return next(v for v in views if v.name == name), robot


def _orders(name: str, robot: Robot, csrf: str) -> str:
    why_not = allowed(robot.emergency_stop, robot.maintenance_mode)
    forms = []
    for action, order in ACTIONS.items():
        if why_not[action] is None:
            forms.append(button_form(f"{_url(name)}/{action}", order.label, csrf,
                                     css=order.css, name=action))
        else:
            forms.append(f'<button type="button" disabled title="{esc(why_not[action])}" '
                         f'data-action="{action}">{esc(order.label)}</button>')
    return f'<div class="actions">{"".join(forms)}</div>'


def _summary(view: RobotView, robot: Robot, csrf: str) -> str:
    battery = "-" if view.battery_pct is None else f"{view.battery_pct:.0f} %"
    fault = "-" if view.fault_code is None else f"{view.fault_code}: {view.fault_message or ''}"
    pose = "-" if view.x_m is None else (
        f"x {view.x_m:.2f} m, y {view.y_m or 0:.2f} m, {view.theta_rad or 0:.2f} rad"
        f" on {view.map_name or 'the map'}")
    rows = (("Condition", f'<span class="status c-{view.condition}">{view.condition}</span>'),
            ("State", esc(view.state or "-")), ("Place", esc(view.place or "-")),
            ("Pose", esc(pose)), ("Battery", esc(battery)), ("Fault", esc(fault)),
            ("Job", esc(view.job or "-")),
            ("Server's orders", esc(", ".join(
                [w for w, on in (("e-stop", robot.emergency_stop),
                                 ("maintenance", robot.maintenance_mode)) if on]) or "none")),
            ("Last seen", esc(when(view.last_seen) or "never")),
            ("Profile", esc(view.profile or "-")))
    table = "".join(f"<tr><th>{k}</th><td>{v}</td></tr>" for k, v in rows)
    return (f'<div id="robot-view" data-condition="{view.condition}">'
            f'<table class="facts">{table}</table>{_orders(view.name, robot, csrf)}'
            '<p class="note">Resume lifts the server\'s e-stop; an e-stop pressed on the robot '
            "is released on the robot.</p></div>")


async def _history(http: HttpRequest, name: str, robot_id: int) -> str:
    async with server_of(http).db.read() as session:
        notes = (await session.execute(
            select(Notification).where(Notification.robot_name == name)
            .order_by(Notification.id.desc()).limit(HISTORY))).scalars().all()
        alerts = (await session.execute(
            select(Alert).where(Alert.robot_name == name)
            .order_by(Alert.id.desc()).limit(HISTORY))).scalars().all()
        requests = (await session.execute(
            select(Request).where(Request.assigned_robot_id == robot_id)
            .order_by(Request.id.desc()).limit(10))).scalars().all()
    events = "".join(
        f'<tr class="{esc(n.level)}"><td>{esc(when(n.created_at))}</td><td>{esc(n.kind)}</td>'
        f"<td>{esc(n.message)}</td></tr>" for n in notes) or \
        '<tr><td colspan="3" class="empty">Nothing yet.</td></tr>'
    alert_rows = "".join(
        f'<tr id="robot-alert-{a.id}"><td>{esc(when(a.created_at))}</td><td>{esc(a.kind)}</td>'
        f"<td>{esc(a.message)}</td><td>{'open' if a.resolved_at is None else 'resolved'}"
        f"{'' if a.resolution is None else ': ' + esc(a.resolution)}</td></tr>"
        for a in alerts) or '<tr><td colspan="4" class="empty">None.</td></tr>'
    request_rows = "".join(
        f"<tr><td>{r.id}</td><td>{esc(r.status)}</td><td>{esc(when(r.status_changed_at))}"
        "</td></tr>" for r in requests) or '<tr><td colspan="3" class="empty">None.</td></tr>'
    return ("<h3>Events</h3><table><thead><tr><th>When</th><th>What</th><th>Message</th>"
            f"</tr></thead><tbody>{events}</tbody></table>"
            "<h3>Alerts</h3><table><thead><tr><th>When</th><th>Kind</th><th>Message</th>"
            f"<th>Now</th></tr></thead><tbody>{alert_rows}</tbody></table>"
            "<h3>Requests</h3><table><thead><tr><th>#</th><th>Status</th><th>Since</th></tr>"
            f"</thead><tbody>{request_rows}</tbody></table>")


async def _page(http: HttpRequest, login: Login, name: str, message: str | None = None,
                status_code: int = 200) -> Response:
    view, robot = await _view(http, name)
    body = (banner(message)
            + section("robot", f"{_url(name)}/view", f"Robot {name}",
                      _summary(view, robot, login.csrf_token))
            + section("history", f"{_url(name)}/history", "What the server saw",
                      await _history(http, name, robot.id)))
    return html(page(f"Robot {name}", body, user=login.principal.subject,
                     csrf=login.csrf_token, live=True, staff=True), status_code)


@router.get("/robots/{name}")
async def robot_page(name: Name, http: HttpRequest) -> Response:
    login = await login_of(http)
    if login is None:
        return see_other("/login")
    check_role(login, Role.ADMIN)
    return await _page(http, login, name)


@router.get("/robots/{name}/view")
async def robot_view(name: Name, http: HttpRequest) -> Response:
    login = await require_login(http, Role.ADMIN)
    view, robot = await _view(http, name)
    return html(_summary(view, robot, login.csrf_token))


@router.get("/robots/{name}/history")
async def robot_history(name: Name, http: HttpRequest) -> Response:
    await require_login(http, Role.ADMIN)
    _view_now, robot = await _view(http, name)
    return html(await _history(http, name, robot.id))


@router.post("/robots/{name}/{action}")
async def robot_action(name: Name, action: str, http: HttpRequest) -> Response:
    login, _form = await checked_form(http, Role.ADMIN)
    try:
        await act_on_robot(server_of(http), name, action, login.principal.subject)
    except FleetError as exc:
        if exc.status_code == 404:
            raise
        return await _page(http, login, name, exc.message, exc.status_code)
    return see_other(_url(name))
