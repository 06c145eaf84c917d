"""What RelayBot remembers survives a restart of the store (a real SQLite state file)."""

from __future__ import annotations

import asyncio
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from behaviours.persistence import Persisted
from behaviours.profiles.delivery.memory import DELIVERY_MISSION, DeliveryMemory
from robotd.store import StateStore

COORD = st.floats(-50.0, 50.0, allow_nan=False)


def reopened(path: Path) -> tuple[StateStore, DeliveryMemory]:
    store = StateStore(path)
    return store, DeliveryMemory(Persisted(store, DELIVERY_MISSION))


# Feature: relaybot-autonomous-delivery, Property 11: For any customer position where QR
# verification occurs, that position should be stored and retrievable for return navigation.
@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(1, 2**63 - 1), COORD, COORD, st.booleans())
def test_property_11_customer_position_survives_a_restart(
    order_id: int, x_m: float, y_m: float, loaded: bool
) -> None:
    """The verified order, its customer's position and the parcel are read back after a
    restart, exactly."""
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "state.sqlite3"
        store, memory = reopened(path)

        async def serve() -> None:
            await memory.verified(order_id, x_m, y_m)
            if loaded:
                await memory.loaded()

        asyncio.run(serve())
        store.close()
        store, again = reopened(path)
        try:
            assert again.persisted.restored
            assert again.order_id == order_id
            assert again.customer_position() == (x_m, y_m)
            assert again.parcel_in_box is loaded
        finally:
            store.close()


def test_a_hand_over_forgets_the_customer(tmp_path: Path) -> None:
    """After the hand-over: no order, no position, box empty; the delivered order is kept."""
    store, memory = reopened(tmp_path / "s.sqlite3")

    async def main() -> None:
        await memory.verified(7, 1.0, 2.0)
        await memory.loaded()
        await memory.handed_over()

    asyncio.run(main())
    assert (memory.order_id, memory.customer_position(), memory.parcel_in_box) == (
        None, None, False)
    assert memory.values()["delivered_order_id"] == 7
    store.close()


def test_a_position_that_is_not_finite_is_refused(tmp_path: Path) -> None:
    """NaN or infinity cannot be driven back to: ValueError, nothing stored."""
    store, memory = reopened(tmp_path / "s.sqlite3")
    with pytest.raises(ValueError, match="not finite"):
        asyncio.run(memory.verified(7, float("nan"), 0.0))
    assert memory.order_id is None
    store.close()
