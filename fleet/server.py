"""The fleet server's state: database, clock, settings and the background monitors.

The HTTP app holds one ``FleetServer`` (``app.state.fleet``). Its lifespan calls ``start()``
and ``stop()``; a simulator that drives the app through ``httpx.ASGITransport`` (which runs no
lifespan) calls them itself, and can run a monitor pass at will with ``check_timeouts()`` and
``check_offline()``.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Awaitable, Callable
from functools import partial
from pathlib import Path
from typing import Any

import structlog
from sqlalchemy import text

from fleet.auth import Authenticator
from fleet.cache import SiteCache
from fleet.clock import Clock, system_clock
from fleet.db import SITE, WRITE, Database
from fleet.pg_listen import PgListener
from fleet.push import EventHub, Webhooks
from fleet.services.assignment import process_queue
from fleet.services.exchange import RobotViews
from fleet.services.offline import check_offline
from fleet.services.site_status import StatusWrites
from fleet.services.timeouts import any_timed_out, check_timeouts
from fleet.settings import FleetSettings, load_settings, store_settings
from fleet.site import Site, apply_site, load_site
from fleet.tokens import TOKENS

log = structlog.get_logger(__name__)

PING_FLUSH_S = 1.0
EVENTS_POLL_S = {"sqlite": 1.0, "postgresql": 10.0}
"""How often the event hub reads the table besides its wake-ups, by default: on PostgreSQL
every commit wakes it (LISTEN/NOTIFY) and the poll is only a safety net."""


class FleetServer:
    """Args:
        db_url: ``sqlite:///PATH`` (default driver aiosqlite) or ``postgresql://...``.
        site: a site file path or a parsed ``Site``, applied at start.
        clock: returns aware UTC datetimes; the system clock by default.
        settings: values written to the database at start (``FleetSettings`` or a dict of
            PascalCase keys), over whatever it held.
        inline_sqlite: run SQLite calls on the loop's thread (one process, a local file).
        auth_failures_per_min: failed authentications a client address may make a minute
            before it gets 429 (0: no limit).
        events_poll_s: how often the event hub reads the notifications besides its wake-ups
            (None: ``EVENTS_POLL_S`` of the database).
    """

    def __init__(
        self,
        db_url: str,
        site: Site | str | Path | None = None,
        clock: Clock | None = None,
        settings: FleetSettings | dict[str, Any] | None = None,
        *,
        inline_sqlite: bool = False,
        auth_failures_per_min: int = 30,
        events_poll_s: float | None = None,
    ) -> None:
        self.db = Database(db_url, inline_sqlite=inline_sqlite)
        self.clock: Clock = clock or system_clock
        self._site = load_site(site) if isinstance(site, str | Path) else site
        if isinstance(settings, FleetSettings):
            settings = settings.public()
        self._settings = settings
        self.cache = SiteCache(self.db)
        self.views = RobotViews(self.db, self.clock)
        self.statuses = StatusWrites()
        """Quiet site status reports (issue 29), written with the pings."""
        self.auth = Authenticator(self.db, max_failures_per_min=auth_failures_per_min)
        self.events = EventHub(self.db, poll_s=events_poll_s or EVENTS_POLL_S[self.db.dialect])
        self.webhooks = Webhooks(self.db, self.cache.settings)
        # Several server processes on one PostgreSQL: LISTEN/NOTIFY and the sweeps' leader.
        self.listener = PgListener(
            self.db, on_notification=self.events.notified, on_changed=self._changed_elsewhere,
            on_connected=self._listening) if self.db.dialect == "postgresql" else None
        self._tasks: list[asyncio.Task[None]] = []
        self.started = False

    async def start(self, *, monitors: bool = True) -> None:
        """Migrate the schema, apply the site and settings, start the monitors."""
        await self.db.migrate()
        async with self.db.write() as session:
            now = self.clock()
            if self._site is not None:
                await apply_site(session, now, self._site)
            if self._settings:
                await store_settings(session, dict(self._settings))
            if self.db.dialect == "postgresql":
                # Site files may give customer ids; keep the id sequence past them.
                await session.execute(text(
                    "SELECT setval(pg_get_serial_sequence('customers', 'id'), "
                    "COALESCE((SELECT MAX(id) FROM customers), 0) + 1, false)"))
            await process_queue(session, now)
            self.webhooks.urls = (await load_settings(session)).webhook_urls
        self.cache.invalidate()
        self.auth.invalidate()
        if self.listener is not None:
            await self.listener.start()
        self.started = True
        if monitors:
            self.start_monitors()
        log.info("fleet.started", dialect=self.db.dialect, monitors=monitors,
                 events_poll_s=self.events.poll_s, listening=self.listener is not None)

    def _changed_elsewhere(self, topics: set[str]) -> None:
        """Another server process committed a change: drop what it may have made stale."""
        if WRITE in topics:
            self.db.generation += 1  # the robots' snapshot (``RobotViews``)
        if SITE in topics:
            self.cache.invalidate()
        if TOKENS in topics:
            self.auth.invalidate()

    def _listening(self) -> None:
        """(Re)connected to PostgreSQL's notifications: what came meanwhile was not heard."""
        self._changed_elsewhere({WRITE, SITE, TOKENS})
        self.events.notified(None)

    async def leads(self) -> bool:
        """Whether this process runs the site's sweeps (timeouts, offline robots): on
        PostgreSQL the one holding the leader lock (``fleet.pg_listen``); on SQLite, one
        process, always."""
        return self.listener is None or await self.listener.lead()

    def start_monitors(self) -> None:
        if self._tasks:
            return
        self._tasks = [
            asyncio.create_task(self._monitor(
                "timeouts", lambda c: c.timeout_check_period_s, self.check_timeouts,
                site_wide=True)),
            asyncio.create_task(self._monitor(
                "offline", lambda c: c.offline_check_period_s, self.check_offline,
                site_wide=True)),
            asyncio.create_task(self._monitor("pings", lambda c: PING_FLUSH_S, self.flush_pings)),
        ]

    async def stop(self) -> None:
        for task in self._tasks:
            task.cancel()
        for task in self._tasks:
            with contextlib.suppress(asyncio.CancelledError):
                await task
        self._tasks = []
        await self.events.stop()
        await self.webhooks.stop()
        if self.listener is not None:
            await self.listener.stop()
        try:
            await self.flush_pings()
        except Exception:
            log.exception("fleet.pings.flush_failed")
        await self.db.dispose()
        self.started = False
        log.info("fleet.stopped")

    @property
    def site(self) -> Site | None:
        """The site file given at start (its map, for the console), or None."""
        return self._site

    async def settings(self) -> FleetSettings:
        async with self.db.read() as session:
            return await load_settings(session)

    async def flush_pings(self) -> int:
        """Write the robots' pending pings and quiet site statuses (the ping monitor does
        this every second)."""
        return await self.views.flush_pings() + await self.statuses.flush(self.db)

    async def check_timeouts(self) -> list[int]:
        """One pass of the timeout monitor (seed section 10); returns cancelled request ids."""
        await self.flush_pings()
        # A quiet pass (nearly all) is one serialized transaction that reads two statements
        # on a Core connection, as the ORM pass's transaction would but without its cost.
        if not await self.db.run_write(partial(any_timed_out, now=self.clock())):
            return []
        async with self.db.write() as session:
            return await check_timeouts(session, self.clock(), await load_settings(session))

    async def check_offline(self) -> list[str]:
        """One pass of the offline monitor (seed section 13); returns robots gone offline."""
        await self.flush_pings()
        async with self.db.write() as session:
            return await check_offline(session, self.clock(), await load_settings(session))

    async def _monitor(
        self, name: str, period: Callable[[FleetSettings], float],
        check: Callable[[], Awaitable[object]], *, site_wide: bool = False,
    ) -> None:
        """``site_wide``: a sweep of the whole site, run only by the leader (``leads``)."""
        while True:
            try:
                cfg = await self.cache.settings()
                self.webhooks.urls = cfg.webhook_urls  # changed by another process, perhaps
            except Exception:
                log.exception("fleet.monitor.failed", monitor=name)
                cfg = FleetSettings.model_validate({})
            await asyncio.sleep(period(cfg))
            try:
                if site_wide and not await self.leads():
                    continue
                found = await check()
                if found and isinstance(found, list):
                    log.info("fleet.monitor.acted", monitor=name, found=found)
            except Exception:
                log.exception("fleet.monitor.failed", monitor=name)
