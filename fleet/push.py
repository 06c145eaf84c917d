"""Notifications pushed as they are created (issue 27): Server-Sent Events and webhooks.

``EventHub`` feeds ``GET /api/events``. It reads the ``notifications`` table in id order (every
notification is created in a serialized write transaction, so ids grow in commit order, across
server processes too): at once when this process commits one, and every ``poll_s`` for those
of other processes. It runs only while someone listens. Listeners that follow them also get
what its pollers find each pass (``add_poller``), at most about once every ``poll_s``: one cheap
read a pass for the whole process: staff the console's ``robots`` event when a robot's state,
place or fault changed, a customer the ``request`` event when one of its requests did.

``Webhooks`` POSTs each notification this process creates (so behind a load balancer each is
sent once) to every URL of the ``WebhookUrls`` setting, from a bounded queue on its own task
with bounded retries: a request never waits for a webhook, and a slow or dead receiver costs
only dropped deliveries (logged).
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import AsyncIterator, Awaitable, Callable
from dataclasses import dataclass, field

import httpx
import structlog
from sqlalchemy import func, select
from sqlalchemy.ext.asyncio import AsyncSession

from fleet.db import Database
from fleet.models import Notification
from fleet.services.notify import CREATED, NotificationOut, notification_out
from fleet.settings import FleetSettings

log = structlog.get_logger(__name__)

Filter = Callable[[NotificationOut], bool]


@dataclass(frozen=True)
class StaffEvent:
    """A pushed event that is no notification: its SSE event name and JSON body, for the
    staff listeners that follow them (``customer_id`` None) or for that customer's."""

    event: str
    data: str
    customer_id: int | None = None


Pushed = NotificationOut | StaffEvent
Poller = Callable[[], Awaitable[list[StaffEvent]]]
"""Called once a pass while someone listens; returns what changed since its last call."""


@dataclass(eq=False)
class _Subscriber:
    wants: Filter
    staff: bool = False
    customer_id: int | None = None
    queue: asyncio.Queue[Pushed | None] = field(
        default_factory=lambda: asyncio.Queue(maxsize=1000))


class EventHub:
    """Args:
        db: the fleet database.
        poll_s: how often notifications of other server processes are looked for.
    """

    BATCH = 500

    def __init__(self, db: Database, poll_s: float = 1.0) -> None:
        self._db = db
        self.poll_s = poll_s
        self._subscribers: set[_Subscriber] = set()
        self._wake = asyncio.Event()
        self._task: asyncio.Task[None] | None = None
        self._last_id = 0
        self._pollers: list[Poller] = []
        self._polled_at = float("-inf")
        db.after_commit.append(self._committed)

    def add_poller(self, poller: Poller) -> None:
        self._pollers.append(poller)

    def _committed(self, session: AsyncSession) -> None:
        if self._subscribers and session.info.get(CREATED):
            self._wake.set()

    @contextlib.asynccontextmanager
    async def subscribe(self, wants: Filter, *, staff: bool = False,
                        customer_id: int | None = None
                        ) -> AsyncIterator[asyncio.Queue[Pushed | None]]:
        """A queue of the notifications created from now on that ``wants`` accepts, and the
        pollers' events for staff (``staff``) or for this customer (``customer_id``) (None:
        the hub stopped, or the listener fell too far behind)."""
        subscriber = _Subscriber(wants, staff, customer_id)
        if self._task is None or self._task.done():
            self._last_id = await self._newest_id()
            self._subscribers.add(subscriber)
            self._task = asyncio.create_task(self._pump())
        else:
            self._subscribers.add(subscriber)
        log.info("fleet.events.subscribed", listeners=len(self._subscribers))
        try:
            yield subscriber.queue
        finally:
            self._subscribers.discard(subscriber)
            log.info("fleet.events.unsubscribed", listeners=len(self._subscribers))

    async def stop(self) -> None:
        """End every stream (the server is stopping)."""
        for subscriber in list(self._subscribers):
            _offer(subscriber, None)
        self._subscribers.clear()
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task
            self._task = None

    async def _newest_id(self) -> int:
        async with self._db.read() as session:
            return int((await session.execute(select(func.max(Notification.id)))).scalar() or 0)

    async def _pump(self) -> None:
        while self._subscribers:
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(self._wake.wait(), self.poll_s)
            self._wake.clear()
            try:
                await self._deliver_new()
            except Exception:
                log.exception("fleet.events.read_failed")
            await self._poll()

    async def _poll(self) -> None:
        loop = asyncio.get_running_loop()
        if not self._pollers or loop.time() - self._polled_at < self.poll_s * 0.9 or not any(
                s.staff or s.customer_id is not None for s in self._subscribers):
            return
        self._polled_at = loop.time()
        for poller in self._pollers:
            try:
                found = await poller()
            except Exception:
                log.exception("fleet.events.poll_failed")
                continue
            for event in found:
                for subscriber in list(self._subscribers):
                    if not _for(subscriber, event):
                        continue
                    if not _offer(subscriber, event):
                        self._subscribers.discard(subscriber)
                        log.warning("fleet.events.listener_dropped", reason="too far behind")

    async def _deliver_new(self) -> None:
        while True:
            async with self._db.read() as session:
                rows = (await session.execute(
                    select(Notification).where(Notification.id > self._last_id)
                    .order_by(Notification.id).limit(self.BATCH))).scalars().all()
            for row in rows:
                out = notification_out(row)
                self._last_id = row.id
                for subscriber in list(self._subscribers):
                    if subscriber.wants(out) and not _offer(subscriber, out):
                        self._subscribers.discard(subscriber)
                        log.warning("fleet.events.listener_dropped", reason="too far behind")
            if len(rows) < self.BATCH:
                return


def _for(subscriber: _Subscriber, event: StaffEvent) -> bool:
    if event.customer_id is None:
        return subscriber.staff
    return subscriber.customer_id == event.customer_id


def _offer(subscriber: _Subscriber, item: Pushed | None) -> bool:
    try:
        subscriber.queue.put_nowait(item)
    except asyncio.QueueFull:
        with contextlib.suppress(asyncio.QueueEmpty):
            subscriber.queue.get_nowait()  # make room for the end marker
        subscriber.queue.put_nowait(None)
        return False
    return True


class Webhooks:
    """Args:
        db: the fleet database (its commits say which notifications this process created).
        settings: the current settings (``WebhookUrls``, ``WebhookRetries``,
            ``WebhookTimeoutS``).
        transport: the HTTP transport (default: the network).
    """

    QUEUE_MAX = 1000
    BACKOFF_S = 0.5

    def __init__(self, db: Database, settings: Callable[[], Awaitable[FleetSettings]],
                 transport: httpx.AsyncBaseTransport | None = None) -> None:
        self._settings = settings
        self._transport = transport
        self._queue: asyncio.Queue[NotificationOut] = asyncio.Queue(maxsize=self.QUEUE_MAX)
        self._task: asyncio.Task[None] | None = None
        self.urls: tuple[str, ...] | None = None
        """``WebhookUrls`` as last seen (None: not known yet); none: nothing is queued."""
        self.sent = 0
        self.failed = 0
        self.dropped = 0
        db.after_commit.append(self._committed)

    def _committed(self, session: AsyncSession) -> None:
        created: list[Notification] = session.info.get(CREATED) or []
        if self.urls == ():
            return
        for row in created:
            try:
                self._queue.put_nowait(notification_out(row))
            except asyncio.QueueFull:
                self.dropped += 1
                log.warning("fleet.webhook.dropped", notification_id=row.id)
                continue
            if self._task is None or self._task.done():
                self._task = asyncio.create_task(self._run())

    async def stop(self) -> None:
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task
            self._task = None

    async def _run(self) -> None:
        async with httpx.AsyncClient(transport=self._transport) as client:
            while not self._queue.empty():
                item = self._queue.get_nowait()
                try:
                    cfg = await self._settings()
                except Exception:
                    log.exception("fleet.webhook.settings_failed")
                    continue
                self.urls = cfg.webhook_urls
                for url in cfg.webhook_urls:
                    await self._post(client, cfg, url, item)

    async def _post(self, client: httpx.AsyncClient, cfg: FleetSettings, url: str,
                    item: NotificationOut) -> None:
        body = item.model_dump_json().encode()
        headers = {"content-type": "application/json", "x-fleet-event": item.Kind}
        for attempt in range(1 + cfg.webhook_retries):
            if attempt:
                await asyncio.sleep(self.BACKOFF_S * 2 ** (attempt - 1))
            try:
                response = await client.post(url, content=body, headers=headers,
                                             timeout=cfg.webhook_timeout_s)
            except httpx.HTTPError as exc:
                problem = f"{type(exc).__name__}: {exc}"
            else:
                if response.status_code < 300:
                    self.sent += 1
                    return
                problem = f"HTTP {response.status_code}"
            log.info("fleet.webhook.retry", url=url, notification_id=item.Id,
                     attempt=attempt + 1, problem=problem)
        self.failed += 1
        log.warning("fleet.webhook.failed", url=url, notification_id=item.Id,
                    attempts=1 + cfg.webhook_retries)
