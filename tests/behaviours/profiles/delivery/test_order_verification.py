"""Order verification against a real SQLite file with the seed's schema."""

from __future__ import annotations

import asyncio
import sqlite3
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from behaviours.profiles.delivery.orders import (
    Accepted,
    OrderVerifier,
    SqliteOrders,
    create_database,
    sqlite_path,
)
from behaviours.profiles.delivery.qr_payload import Rejected, encode_payload

KEYS = st.text(min_size=8, max_size=32,
               alphabet=st.characters(whitelist_categories=("Lu", "Ll", "Nd")))


def make_db(path: Path, keys: list[str], orders: list[int]) -> None:
    """Customers 1..n with ``keys``; order i belongs to customer ``orders[i-1]``."""
    customers = [(i, f"Name{i}", f"Surname{i}", 7900000 + i, key)
                 for i, key in enumerate(keys, start=1)]
    create_database(path, customers, [(i, c) for i, c in enumerate(orders, start=1)])


@st.composite
def databases(draw: st.DrawFn) -> tuple[list[str], list[int]]:
    keys = draw(st.lists(KEYS, min_size=1, max_size=5))
    orders = draw(st.lists(st.integers(1, len(keys)), min_size=1, max_size=8))
    return keys, orders


def verify(path: Path, payload: bytes) -> Accepted | Rejected:
    return asyncio.run(OrderVerifier(SqliteOrders(path), retry_delays_s=()).verify(payload))


# Feature: relaybot-autonomous-delivery, Property 6: For any order in the database, generating its
# QR code then validating it should return success with the correct order_id.
@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(databases(), st.data())
def test_property_6_order_round_trip(db: tuple[list[str], list[int]], data: st.DataObject) -> None:
    """Every order's own QR code is accepted with its order_id."""
    keys, orders = db
    order_id = data.draw(st.integers(1, len(orders)))
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "orders.db"
        make_db(path, keys, orders)
        payload = encode_payload(order_id, keys[orders[order_id - 1] - 1])
        assert verify(path, payload) == Accepted(order_id)


# Feature: relaybot-autonomous-delivery, Property 7: For any QR code with invalid credentials
# (wrong secret_key or non-existent order_id), validation should fail and trigger rejection audio
# and return to WAITING state. (The audio and the state are the table's: test_states.py.)
@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(databases(), st.integers(1, 20), KEYS)
def test_property_7_invalid_credentials_are_rejected(
    db: tuple[list[str], list[int]], order_id: int, key: str
) -> None:
    """A wrong key or an unknown order is rejected, with the reason."""
    keys, orders = db
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "orders.db"
        make_db(path, keys, orders)
        verdict = verify(path, encode_payload(order_id, key))
    if order_id > len(orders):
        assert verdict == Rejected("unknown_order", f"no order {order_id}")
    elif key != keys[orders[order_id - 1] - 1]:
        assert isinstance(verdict, Rejected) and verdict.reason == "wrong_key"
    else:
        assert verdict == Accepted(order_id)


async def test_a_delivered_order_is_refused(tmp_path: Path) -> None:
    """Once marked delivered, the same QR code is refused as already delivered."""
    path = tmp_path / "orders.db"
    make_db(path, ["secretkey1"], [1])
    store = SqliteOrders(path)
    verifier = OrderVerifier(store)
    assert await verifier.verify(encode_payload(1, "secretkey1")) == Accepted(1)
    await store.mark_delivered(1, "2026-11-25T10:00:00Z")
    verdict = await verifier.verify(encode_payload(1, "secretkey1"))
    assert isinstance(verdict, Rejected) and verdict.reason == "already_delivered"


async def test_the_seed_tables_are_unchanged(tmp_path: Path) -> None:
    """customers and orders keep the seed's columns; deliveries live in their own table."""
    path = tmp_path / "orders.db"
    make_db(path, ["secretkey1"], [1])
    await SqliteOrders(path).mark_delivered(1, "2026-11-25T10:00:00Z")
    with sqlite3.connect(path) as db:
        columns = {t: [r[1] for r in db.execute(f"PRAGMA table_info({t})")]
                   for t in ("customers", "orders")}
    db.close()
    assert columns == {"customers": ["id", "name", "surname", "phone", "secret_key"],
                       "orders": ["id", "customer_id"]}


async def test_a_database_that_stays_locked_is_a_rejection(tmp_path: Path) -> None:
    """A lock held past the timeout and every retry rejects the order; nothing raises."""
    path = tmp_path / "orders.db"
    make_db(path, ["secretkey1"], [1])
    holder = sqlite3.connect(path)
    holder.execute("BEGIN EXCLUSIVE")
    try:
        verifier = OrderVerifier(SqliteOrders(path, timeout_s=0.05), retry_delays_s=(0.01, 0.02))
        verdict = await verifier.verify(encode_payload(1, "secretkey1"))
    finally:
        holder.rollback()
        holder.close()
    assert isinstance(verdict, Rejected) and verdict.reason == "database_unavailable"
    assert "after 3 tries" in verdict.detail


async def test_a_lock_released_during_the_retries_is_accepted(tmp_path: Path) -> None:
    """A lock that goes away before the retries run out costs time, not the order."""
    path = tmp_path / "orders.db"
    make_db(path, ["secretkey1"], [1])
    holder = sqlite3.connect(path)
    holder.execute("BEGIN EXCLUSIVE")
    asyncio.get_running_loop().call_later(0.1, holder.rollback)
    verifier = OrderVerifier(SqliteOrders(path, timeout_s=0.02), retry_delays_s=(0.1, 0.2))
    assert await verifier.verify(encode_payload(1, "secretkey1")) == Accepted(1)
    holder.close()


async def test_a_missing_database_is_a_rejection(tmp_path: Path) -> None:
    """No database file: the customer is refused with a reason, no file is created."""
    verifier = OrderVerifier(SqliteOrders(tmp_path / "none.db"), retry_delays_s=(0.0,))
    verdict = await verifier.verify(encode_payload(1, "secretkey1"))
    assert isinstance(verdict, Rejected) and verdict.reason == "database_unavailable"
    assert not (tmp_path / "none.db").exists()


class TestDatabaseUrl:
    def test_relative_and_absolute(self) -> None:
        """sqlite:///rel is under the base directory; sqlite:////abs is absolute."""
        assert sqlite_path("sqlite:///assets/orders.db", Path("/var/lib/robotd")) == Path(
            "/var/lib/robotd/assets/orders.db")
        assert sqlite_path("sqlite:////srv/orders.db", Path("/x")) == Path("/srv/orders.db")

    def test_other_urls_are_refused(self) -> None:
        """A URL that is not sqlite:///PATH names the key."""
        for url in ("postgresql://x/y", "sqlite:///", "orders.db"):
            with pytest.raises(ValueError, match=r"delivery\.database_url"):
                sqlite_path(url, Path("/x"))
