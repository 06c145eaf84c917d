"""The FastAPI application of the fleet server.

``create_app(db_url, site=None, clock=None, settings=None)`` builds the app around one
``FleetServer`` (``app.state.fleet``). Served by uvicorn, its lifespan starts and stops the
server and the monitors. Driven in-process through ``httpx.ASGITransport`` (no lifespan), the
caller runs ``await app.state.fleet.start()`` and ``await app.state.fleet.stop()`` itself.
"""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Any

import structlog
from fastapi import FastAPI
from starlette.types import Receive, Scope, Send

from fleet.api import admin, alerts, events, requests, robot, tokens
from fleet.api.auth import Authenticate
from fleet.api.body_limit import BodyLimit
from fleet.api.docs import add_offline_docs
from fleet.api.error_bodies import add_error_handlers
from fleet.api.exchange_fast import ExchangeFastPath
from fleet.api.methods import AllowedMethods
from fleet.api.requests_fast import RequestsFastPath
from fleet.clock import Clock
from fleet.console import assets as console_assets
from fleet.console import customer as console_customer
from fleet.console import login as console_login
from fleet.console import robot_pages as console_robots
from fleet.console import settings_page as console_settings
from fleet.console import site_map as console_site
from fleet.console import staff as console_staff
from fleet.console.request_push import RequestChanges
from fleet.console.robot_push import RobotChanges
from fleet.console.web import cookie_caller, is_console_path
from fleet.server import FleetServer
from fleet.settings import FleetSettings
from fleet.site import Site

log = structlog.get_logger(__name__)


class FleetApp(FastAPI):
    """The FastAPI app with the robots' data exchange and the customers' and staff's request
    reads answered before its middleware and routing (``fleet.api.exchange_fast``,
    ``fleet.api.requests_fast``): each is called about once a second by each robot or person."""

    def __init__(self, server: FleetServer, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self._front = BodyLimit(AllowedMethods(
            Authenticate(ExchangeFastPath(RequestsFastPath(super().__call__, server), server),
                         server.auth, own_auth=is_console_path,
                         cookie_caller=cookie_caller(server)),
            lambda: self.routes))

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        await self._front(scope, receive, send)


def create_app(
    db_url: str,
    site: Site | str | Path | None = None,
    clock: Clock | None = None,
    settings: FleetSettings | dict[str, Any] | None = None,
    *,
    monitors: bool = True,
    inline_sqlite: bool = False,
    auth_failures_per_min: int = 30,
    events_poll_s: float | None = None,
) -> FastAPI:
    """Args:
        db_url: ``sqlite:///PATH`` or ``postgresql://USER@HOST/DB`` (async drivers are chosen).
        site: site TOML file (or a parsed ``Site``) applied at start.
        clock: the wall clock (aware UTC datetimes); all server logic takes "now" from it.
        settings: settings written at start over the stored ones.
        monitors: whether the lifespan starts the timeout and offline monitors.
        inline_sqlite: SQLite calls on the loop's thread, no aiosqlite worker threads (a
            single-process server on a local file; see ``fleet.sqlite_inline``).
        auth_failures_per_min: failed authentications a client address may make a minute
            before it gets 429 (0: no limit; ``fleet.ratelimit``).
        events_poll_s: how often the event stream reads new notifications besides its
            wake-ups (None: 1 s on SQLite, 10 s on PostgreSQL, where LISTEN/NOTIFY wakes it).
    """
    server = FleetServer(db_url, site=site, clock=clock, settings=settings,
                         inline_sqlite=inline_sqlite,
                         auth_failures_per_min=auth_failures_per_min,
                         events_poll_s=events_poll_s)

    @asynccontextmanager
    async def lifespan(_app: FastAPI) -> AsyncIterator[None]:
        if not server.started:
            await server.start(monitors=monitors)
        try:
            yield
        finally:
            await server.stop()

    app = FleetApp(
        server,
        title="robotd fleet server",
        version="1",
        summary="Laundry robot fleet: requests, assignment, data exchange, monitors.",
        lifespan=lifespan,
        docs_url=None,  # served from local assets below, not a CDN
        redoc_url=None,
    )
    app.state.fleet = server
    app.include_router(requests.router)
    app.include_router(robot.router)
    app.include_router(admin.router)
    app.include_router(tokens.router)
    app.include_router(alerts.router)
    app.include_router(events.router)
    for console in (console_login, console_staff, console_customer, console_assets,
                    console_site, console_robots, console_settings):
        app.include_router(console.router)
    server.events.add_poller(RobotChanges(server.db, server.clock))
    server.events.add_poller(RequestChanges(server.db, server.clock))
    add_error_handlers(app)
    add_offline_docs(app)

    @app.get("/health", tags=["meta"])
    async def health() -> dict[str, str]:
        return {"status": "ok"}

    return app
