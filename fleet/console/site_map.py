"""The staff's site map at ``/site``: every robot placed on the site, coloured by its
condition (moving, idle, fault, e-stop, offline), with battery and fault; kept live by the
``robots`` events of ``GET /api/events`` (``console.js`` moves the markers) and the robots'
table below it (re-fetched like every live section).

A site whose file names a ``map`` shows that picture with the robots at their poses; any
other shows the laundry schematic: the rooms along the line's loop, the base first.
"""

from __future__ import annotations

from fastapi import APIRouter
from fastapi import Request as HttpRequest
from fastapi.responses import Response
from sqlalchemy import select

from fleet.api.deps import server_of
from fleet.console import site_svg
from fleet.console.html import esc, page, section
from fleet.console.map_image import MapError, SiteMap, load_map
from fleet.console.robot_table import views_table
from fleet.console.robot_views import RobotView, robot_views
from fleet.console.sessions import Login
from fleet.console.web import (
    SECURITY_HEADERS,
    ConsoleRoute,
    check_role,
    html,
    login_of,
    require_login,
    see_other,
)
from fleet.errors import NotFound
from fleet.models import Beacon, Room
from fleet.services import lines
from fleet.tokens import Role

router = APIRouter(route_class=ConsoleRoute, include_in_schema=False)

LEGEND = (("moving", "moving"), ("idle", "idle"), ("fault", "fault"), ("estop", "e-stop"),
          ("offline", "offline"))


async def views_now(http: HttpRequest) -> list[RobotView]:
    """Every robot's view, on the robots' latest reports."""
    server = server_of(http)
    await server.flush_pings()
    async with server.db.read() as session:
        return await robot_views(session, server.clock())


def site_map_of(http: HttpRequest) -> SiteMap | None:
    """The site file's map, or None (no map, or one that cannot be read: logged once a
    request, and the schematic is shown)."""
    site = server_of(http).site
    if site is None or site.map is None:
        return None
    return load_map(site.map)


async def _drawing(http: HttpRequest, views: list[RobotView]) -> str:
    try:
        site_map = site_map_of(http)
    except MapError as exc:
        return f'<p class="error">{esc(exc)}</p>' + await _schematic(http, views)
    if site_map is not None:
        site = server_of(http).site
        placements = site.odom_placements() if site is not None else {}
        unposed = [v.name for v in views
                   if site_svg.on_site_map(v, site_map, placements) is None]
        note = (f'<p class="note" id="no-pose">Without a pose on the map (see the table): '
                f'{esc(", ".join(unposed))}</p>' if unposed else "")
        return site_svg.picture(site_map, views, placements) + note
    return await _schematic(http, views)


async def _schematic(http: HttpRequest, views: list[RobotView]) -> str:
    async with server_of(http).db.read() as session:
        rooms = list((await session.execute(select(Room.name).order_by(Room.id))).scalars())
        base = (await session.execute(
            select(Room.name).join(Beacon, Beacon.room_id == Room.id)
            .where(Beacon.is_base.is_(True)).order_by(Beacon.id).limit(1))).scalar()
        site_lines = await lines.all_lines(session)
    on_a_line = {room for members in site_lines.values() for room in members}
    names = ", ".join(f"{name} ({len(members)} rooms)" for name, members in site_lines.items())
    note = (f'<p class="note">Line{"s" if len(site_lines) > 1 else ""}: {esc(names)}</p>'
            if site_lines else "")
    # The loop runs through the base and every room on a line (all rooms if none is).
    shown = [r for r in rooms if r == base or r in on_a_line] if on_a_line else rooms
    return site_svg.schematic(shown, base, views) + note


def _legend() -> str:
    items = "".join(f'<li><span class="dot c-{css}"></span>{esc(text)}</li>'
                    for css, text in LEGEND)
    return f'<ul class="legend">{items}</ul>'


async def _site(http: HttpRequest, login: Login) -> Response:
    views = await views_now(http)
    drawing = (f'<section id="map"><h2>Site map</h2>{_legend()}'
               f'<div class="drawing">{await _drawing(http, views)}</div></section>')
    body = drawing + section("robot-list", "/console/site/robots", "Robots",
                             views_table(views))
    return html(page("Site console - site map", body, user=login.principal.subject,
                     csrf=login.csrf_token, live=True, staff=True))


@router.get("/site")
async def site(http: HttpRequest) -> Response:
    login = await login_of(http)
    if login is None:
        return see_other("/login")
    check_role(login, Role.ADMIN)
    return await _site(http, login)


@router.get("/console/site/robots")
async def robots(http: HttpRequest) -> Response:
    await require_login(http, Role.ADMIN)
    return html(views_table(await views_now(http)))


@router.get("/console/site/map.png")
async def map_png(http: HttpRequest) -> Response:
    await require_login(http, Role.ADMIN)
    try:
        site_map = site_map_of(http)
    except MapError as exc:
        raise NotFound(str(exc)) from exc
    if site_map is None:
        msg = "this site has no map (its site file names none)"
        raise NotFound(msg)
    return Response(site_map.png, media_type="image/png",
                    headers={**SECURITY_HEADERS, "Cache-Control": "private, max-age=3600"})
