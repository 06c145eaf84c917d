"""Notifications pushed as they are created (issue 27): Server-Sent Events and webhooks.

``EventHub`` feeds ``GET /api/events``. It reads the ``notifications`` table in id order (every
notification is created in a serialized write transaction, so ids grow in commit order, across
server processes too): at once when this process commits one or is told of one another
process committed (PostgreSQL ``LISTEN``, ``fleet.pg_listen``), and every ``poll_s`` besides.
Each listener has its own cursor, the id of the last notification it was given: one that
subscribes with ``after_id`` (the ``Last-Event-ID`` of a reconnecting stream) gets what it
missed, then what comes, each once and in order. It runs only while someone listens.
Listeners that follow them also get what its pollers find (``add_poller``), about once every
``watch_s``: one cheap read a pass for the whole process: staff the console's ``robots`` event
when a robot's state, place or fault changed, a customer the ``request`` event when one of its
requests did.

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
    cursor: int
    """The id of the last notification this listener was given (or passed over)."""
    staff: bool = False
    customer_id: int | None = None
    queue: asyncio.Queue[Pushed | None] = field(
        default_factory=lambda: asyncio.Queue(maxsize=1000))

    @property
    def follows_pollers(self) -> bool:
        return self.staff or self.customer_id is not None


class EventHub:
    """Args:
        db: the fleet database.
        poll_s: how often notifications are looked for besides the wake-ups (this process's
            commits, and other processes' as ``notified`` tells).
        watch_s: how often the pollers look for changes while a listener follows them.
    """

    BATCH = 500

    def __init__(self, db: Database, poll_s: float = 1.0, watch_s: float = 1.0) -> None:
        self._db = db
        self.poll_s = poll_s
        self.watch_s = watch_s
        self._subscribers: set[_Subscriber] = set()
        self._wake = asyncio.Event()
        self._task: asyncio.Task[None] | None = None
        self._pollers: list[Poller] = []
        self._polled_at = float("-inf")
        db.after_commit.append(self._committed)

    def add_poller(self, poller: Poller) -> None:
        self._pollers.append(poller)

    def _committed(self, session: AsyncSession) -> None:
        if self._subscribers and session.info.get(CREATED):
            self._wake.set()

    def notified(self, _notification_id: int | None = None) -> None:
        """A notification was committed (by any process; None: perhaps some were missed)."""
        if self._subscribers:
            self._wake.set()

    @contextlib.asynccontextmanager
    async def subscribe(self, wants: Filter, after_id: int | None = None, *,
                        staff: bool = False, customer_id: int | None = None
                        ) -> AsyncIterator[asyncio.Queue[Pushed | None]]:
        """A queue of the notifications that ``wants`` accepts, in id order: those created
        from now on, or with ``after_id`` all those after it; and the pollers' events for
        staff (``staff``) or for this customer (``customer_id``) (None: the hub stopped, or
        the listener fell too far behind)."""
        cursor = after_id if after_id is not None else await self._newest_id()
        subscriber = _Subscriber(wants, cursor, staff, customer_id)
        self._subscribers.add(subscriber)
        if self._task is None or self._task.done():
            self._task = asyncio.create_task(self._pump())
        if after_id is not None:
            self._wake.set()  # catch it up now
        log.info("fleet.events.subscribed", listeners=len(self._subscribers), after_id=after_id)
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
            self._wake.clear()
            try:
                await self._deliver_new()
            except Exception:
                log.exception("fleet.events.read_failed")
            await self._poll()
            if not self._wake.is_set():
                with contextlib.suppress(TimeoutError):
                    await asyncio.wait_for(self._wake.wait(), self._wait_s())

    def _watched(self) -> bool:
        return bool(self._pollers) and any(s.follows_pollers for s in self._subscribers)

    def _wait_s(self) -> float:
        """Until the next look: the notifications' poll, or sooner the pollers' turn."""
        if not self._watched():
            return self.poll_s
        due_s = self._polled_at + self.watch_s - asyncio.get_running_loop().time()
        return max(0.0, min(self.poll_s, due_s))

    async def _poll(self) -> None:
        loop = asyncio.get_running_loop()
        if not self._watched() or loop.time() - self._polled_at < self.watch_s * 0.9:
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
        """Every listener gets, in id order, each notification after its cursor that it
        wants; read from the lowest cursor, BATCH rows at a time."""
        while self._subscribers:
            listeners = list(self._subscribers)
            floor = min(s.cursor for s in listeners)
            async with self._db.read() as session:
                rows = (await session.execute(
                    select(Notification).where(Notification.id > floor)
                    .order_by(Notification.id).limit(self.BATCH))).scalars().all()
            for row in rows:
                out: NotificationOut | None = None
                for subscriber in listeners:
                    if row.id <= subscriber.cursor or subscriber not in self._subscribers:
                        continue
                    subscriber.cursor = row.id
                    out = out or notification_out(row)
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
