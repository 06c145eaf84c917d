"""The orders database (the seed's SQLite schema, unchanged) and QR verification against it.

``OrderStore`` is the small Protocol the mission sees; ``SqliteOrders`` is the real one.
sqlite3 is the standard library, not hardware, so it lives here rather than behind a hal port;
tests use a real SQLite file. sqlite3 blocks, so every call runs in a worker thread
(``asyncio.to_thread``: the module has no async API, and a locked database would otherwise stall
the control loop for the busy timeout). Deliveries are recorded in a table of their own
(``deliveries``) so the seed's ``customers`` and ``orders`` tables stay exactly as they are.
"""

from __future__ import annotations

import asyncio
import hmac
import sqlite3
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol, TypeVar

import structlog

from behaviours.profiles.delivery.qr_payload import Claim, Rejected, parse_payload

log = structlog.get_logger(__name__)
T = TypeVar("T")

QUERY_TIMEOUT_S = 5.0
"""The seed: a 5 s timeout on every query (sqlite3's busy timeout)."""
RETRY_DELAYS_S = (0.5, 1.0, 2.0)
"""The seed: up to 3 retries with exponential backoff, then reject and tell the customer."""

SCHEMA = """
CREATE TABLE IF NOT EXISTS customers (
    id INTEGER NOT NULL PRIMARY KEY,
    name VARCHAR NOT NULL,
    surname VARCHAR NOT NULL,
    phone INTEGER NOT NULL,
    secret_key VARCHAR NOT NULL
);
CREATE TABLE IF NOT EXISTS orders (
    id INTEGER NOT NULL PRIMARY KEY,
    customer_id INTEGER,
    FOREIGN KEY(customer_id) REFERENCES customers (id)
);
"""
"""The seed's ``db_models.py`` (Customer, Order) as SQLAlchemy creates it for SQLite."""

DELIVERIES = """
CREATE TABLE IF NOT EXISTS deliveries (
    order_id INTEGER NOT NULL PRIMARY KEY REFERENCES orders (id),
    delivered_at TEXT NOT NULL
);
"""

_NO_KEY = b"\x00" * 32
"""Compared against when the order is unknown, so both refusals take about as long."""


@dataclass(frozen=True, slots=True)
class OrderRow:
    order_id: int
    secret_key: str
    delivered: bool


@dataclass(frozen=True, slots=True)
class Accepted:
    order_id: int


Verdict = Accepted | Rejected


class DatabaseUnavailable(Exception):
    """The database could not answer (locked past the timeout, missing, corrupt)."""


class OrderStore(Protocol):
    """What order verification needs from the database; every call may raise
    ``DatabaseUnavailable``."""

    async def lookup(self, order_id: int) -> OrderRow | None: ...
    async def mark_delivered(self, order_id: int, at_iso: str) -> None: ...


def sqlite_path(database_url: str, base_dir: Path) -> Path:
    """The file of a ``sqlite:///relative`` or ``sqlite:////absolute`` URL (SQLAlchemy's form).

    A relative path is relative to ``base_dir`` (the state directory), not to the daemon's
    working directory, which systemd sets to ``/``.
    """
    prefix = "sqlite:///"
    if not database_url.startswith(prefix) or database_url == prefix:
        msg = f"delivery.database_url: expected sqlite:///PATH, got {database_url!r}"
        raise ValueError(msg)
    path = Path(database_url[len(prefix):])
    return path if path.is_absolute() else base_dir / path


class SqliteOrders:
    """The orders database in a SQLite file; one short connection per call, in a thread."""

    def __init__(self, path: Path, timeout_s: float = QUERY_TIMEOUT_S) -> None:
        self.path = path
        self.timeout_s = timeout_s

    def _connect(self) -> sqlite3.Connection:
        if not self.path.exists():
            msg = f"no orders database at {self.path}"
            raise DatabaseUnavailable(msg)
        return sqlite3.connect(self.path, timeout=self.timeout_s)

    def _lookup(self, order_id: int) -> OrderRow | None:
        try:
            with self._connect() as db:
                db.execute(DELIVERIES)
                row = db.execute(
                    "SELECT orders.id, customers.secret_key, deliveries.order_id IS NOT NULL"
                    " FROM orders JOIN customers ON customers.id = orders.customer_id"
                    " LEFT JOIN deliveries ON deliveries.order_id = orders.id"
                    " WHERE orders.id = ?", (order_id,)).fetchone()
        except sqlite3.Error as exc:
            raise DatabaseUnavailable(f"{self.path}: {exc}") from exc
        if row is None:
            return None
        return OrderRow(int(row[0]), str(row[1]), bool(row[2]))

    def _mark(self, order_id: int, at_iso: str) -> None:
        try:
            with self._connect() as db:
                db.execute(DELIVERIES)
                db.execute("INSERT OR IGNORE INTO deliveries (order_id, delivered_at)"
                           " VALUES (?, ?)", (order_id, at_iso))
        except sqlite3.Error as exc:
            raise DatabaseUnavailable(f"{self.path}: {exc}") from exc

    async def lookup(self, order_id: int) -> OrderRow | None:
        return await self._off_loop(self._lookup, order_id)

    async def mark_delivered(self, order_id: int, at_iso: str) -> None:
        await self._off_loop(self._mark, order_id, at_iso)

    async def _off_loop(self, call: Callable[..., T], *args: Any) -> T:
        # The busy timeout bounds waiting for a lock; this bounds the rest (a hung file system).
        # The thread cannot be cancelled; it ends by itself, its answer is dropped.
        limit_s = self.timeout_s + 1.0
        try:
            async with asyncio.timeout(limit_s):
                return await asyncio.to_thread(call, *args)
        except TimeoutError as exc:
            msg = f"{self.path}: no answer within {limit_s:g} s"
            raise DatabaseUnavailable(msg) from exc


def create_database(path: Path, customers: list[tuple[int, str, str, int, str]],
                    orders: list[tuple[int, int]]) -> None:
    """A new orders database with the seed's schema (for the simulator and tests; blocking)."""
    with sqlite3.connect(path) as db:
        db.executescript(SCHEMA + DELIVERIES)
        db.executemany("INSERT INTO customers VALUES (?, ?, ?, ?, ?)", customers)
        db.executemany("INSERT INTO orders VALUES (?, ?)", orders)
    # sqlite3's context manager commits but does not close.
    db.close()


class OrderVerifier:
    """QR payload → ``Accepted`` or ``Rejected``; never raises."""

    def __init__(self, store: OrderStore, retry_delays_s: tuple[float, ...] = RETRY_DELAYS_S
                 ) -> None:
        self.store = store
        self.retry_delays_s = retry_delays_s
        self.counts: dict[str, int] = {}

    async def verify(self, payload: bytes) -> Verdict:
        parsed = parse_payload(payload)
        verdict = parsed if isinstance(parsed, Rejected) else await self._check(parsed)
        key = "accepted" if isinstance(verdict, Accepted) else verdict.reason
        self.counts[key] = self.counts.get(key, 0) + 1
        if isinstance(verdict, Rejected):
            log.info("delivery.order_rejected", reason=verdict.reason, detail=verdict.detail)
        else:
            log.info("delivery.order_accepted", order_id=verdict.order_id)
        return verdict

    async def _check(self, claim: Claim) -> Verdict:
        row = await self._lookup(claim.order_id)
        if isinstance(row, Rejected):
            return row
        given = claim.secret_key.encode("utf-8")
        stored = row.secret_key.encode("utf-8", "surrogatepass") if row else _NO_KEY
        matches = hmac.compare_digest(given, stored)
        if row is None:
            return Rejected("unknown_order", f"no order {claim.order_id}")
        if not matches:
            return Rejected("wrong_key", f"secret_key does not match order {claim.order_id}")
        if row.delivered:
            return Rejected("already_delivered", f"order {claim.order_id} was delivered already")
        return Accepted(claim.order_id)

    async def _lookup(self, order_id: int) -> OrderRow | Rejected | None:
        delays = (*self.retry_delays_s, None)
        for attempt, delay_s in enumerate(delays, start=1):
            try:
                return await self.store.lookup(order_id)
            except DatabaseUnavailable as exc:
                log.warning("delivery.database_error", attempt=attempt, error=str(exc))
                if delay_s is None:
                    return Rejected("database_unavailable",
                                    f"orders database did not answer after {attempt} tries: {exc}")
                await asyncio.sleep(delay_s)
        raise AssertionError("unreachable")  # pragma: no cover
