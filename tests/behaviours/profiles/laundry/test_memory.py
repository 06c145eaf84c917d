"""What the laundry robot remembers of its request, what it holds and where it was."""

from __future__ import annotations

from datetime import UTC, datetime
from typing import Any

import pytest

from behaviours.context import RobotContext
from behaviours.profiles.laundry.directive import (
    BadResponse,
    Directive,
    parse_exchange_response,
)
from behaviours.profiles.laundry.memory import LAUNDRY_MISSION, LaundryMemory
from hal.backend import Devices


class DictStore:
    def __init__(self) -> None:
        self.values: dict[str, Any] = {}
        self.flushes = 0

    def get(self, key: str, default: Any = None) -> Any:
        return self.values.get(key, default)

    def put(self, key: str, value: Any) -> None:
        self.values[key] = value

    def delete(self, key: str) -> None:
        self.values.pop(key, None)

    async def flush(self) -> None:
        self.flushes += 1


Events = list[tuple[str, dict[str, Any]]]


def memory(store: DictStore, events: Events) -> LaundryMemory:
    ctx = RobotContext(Devices(), None, store,  # type: ignore[arg-type]
                       lambda: datetime(2026, 1, 1, tzinfo=UTC),
                       lambda kind, **f: events.append((kind, f)))
    return LaundryMemory(ctx, "base")


def told(rid: int | None, status: str | None) -> Directive:
    return Directive(line_following=True, request_id=rid, request_status=status)


class TestDirective:
    def test_request_id_and_status_are_read_when_given(self) -> None:
        d = parse_exchange_response({"RequestId": 4, "RequestStatus": "LaundryLoaded"})
        assert (d.request_id, d.request_status) == (4, "LaundryLoaded")
        assert parse_exchange_response({}).request_id is None

    @pytest.mark.parametrize(("body", "field"), [({"RequestId": "4"}, "RequestId"),
                                                 ({"RequestId": True}, "RequestId"),
                                                 ({"RequestStatus": 3}, "RequestStatus")])
    def test_a_bad_request_field_is_named(self, body: dict[str, Any], field: str) -> None:
        with pytest.raises(BadResponse, match=f"response.{field}: expected"):
            parse_exchange_response(body)


class TestLaundryMemory:
    async def test_it_holds_what_the_request_status_says_through_a_lifecycle(self) -> None:
        """Dirty from LaundryLoaded until let go at the base; clean from the washing's way
        back to the room until the customer takes it out."""
        store, events = DictStore(), []
        mem = memory(store, events)
        seen = []
        for rid, status, room in [(1, "Accepted", None), (1, "ArrivedAtRoom", "101"),
                                  (1, "LaundryLoaded", None), (None, None, "base"),
                                  (1, "FinishedWashingGoingToRoom", None),
                                  (1, "FinishedWashingArrivedAtRoom", "101"),
                                  (1, "FinishedWashingGoingToBase", None),
                                  (None, None, "base")]:
            if room is not None:
                mem.arrived(room)
            await mem.observe(told(rid, status))
            seen.append((mem.holding, mem.report()))
        assert seen == [
            ("none", None), ("none", None), ("dirty", {"Laundry": "dirty", "RequestId": 1}),
            ("none", None), ("clean", {"Laundry": "clean", "RequestId": 1}),
            ("clean", {"Laundry": "clean", "RequestId": 1}), ("none", None), ("none", None)]
        assert [f["holding"] for k, f in events if k == "laundry.holding"] == [
            "dirty", "none", "clean", "none"]

    async def test_a_restart_restores_and_reconciles_with_the_first_answer(self) -> None:
        store, events = DictStore(), []
        first = memory(store, events)
        first.arrived("101")
        first.heading("base")
        await first.observe(told(1, "LaundryLoaded"))
        events.clear()
        again = memory(store, events)
        assert again.holding == "dirty"
        await again.observe(told(1, "LaundryLoaded"))
        kinds = [k for k, _ in events]
        assert kinds[:2] == ["persist.restored", "laundry.restored"]
        reconciled = dict(events)["laundry.reconciled"]
        assert (reconciled["agrees"], reconciled["holding"], reconciled["request_id"]) == (
            True, "dirty", 1)

    async def test_laundry_the_server_let_go_away_from_the_base_is_not_forgotten(self) -> None:
        """Seed section 13: an admin must resolve it; the robot keeps saying what it holds."""
        store, events = DictStore(), []
        mem = memory(store, events)
        mem.arrived("101")
        await mem.observe(told(1, "LaundryLoaded"))
        await mem.observe(told(None, None))
        await mem.observe(told(None, None))
        assert mem.report() == {"Laundry": "dirty", "RequestId": 1}
        assert [k for k, _ in events].count("laundry.unclaimed") == 1

    async def test_a_change_is_durable_before_observe_returns(self) -> None:
        store = DictStore()
        mem = memory(store, [])
        await mem.observe(told(2, "LaundryLoaded"))
        assert store.flushes == 1
        assert store.values[LAUNDRY_MISSION.key]["values"]["holding"] == "dirty"
