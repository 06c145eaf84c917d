"""The mission-state facility: declared records restored, written at each change; the latch."""

from __future__ import annotations

from datetime import UTC, datetime
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from behaviours.context import KeyValueStore, RobotContext
from behaviours.persistence import LATCH_KEY, EStopLatch, MissionRecord, Persisted
from hal.backend import Devices


class DictStore:
    """A store in a dict that counts flushes (what a durable write would be)."""

    def __init__(self, values: dict[str, Any] | None = None) -> None:
        self.values: dict[str, Any] = dict(values or {})
        self.puts = 0
        self.flushes = 0
        self.fail = False

    def get(self, key: str, default: Any = None) -> Any:
        return self.values.get(key, default)

    def put(self, key: str, value: Any) -> None:
        self.puts += 1
        self.values[key] = value

    def delete(self, key: str) -> None:
        self.values.pop(key, None)

    async def flush(self) -> None:
        if self.fail:
            msg = "disk I/O error"
            raise OSError(msg)
        self.flushes += 1


RECORD = MissionRecord("test.mission", 2, {"request_id": None, "holding": "none"})


def clock() -> datetime:
    return datetime(2026, 1, 1, 12, 0, tzinfo=UTC)


class TestMissionRecord:
    def test_defaults_json_cannot_hold_are_refused(self) -> None:
        with pytest.raises(ValueError, match=r"x\.y: field defaults are not JSON-able"):
            MissionRecord("x.y", 1, {"when": object()})

    def test_the_dict_store_is_a_key_value_store(self) -> None:
        assert isinstance(DictStore(), KeyValueStore)


class TestPersisted:
    def test_a_first_start_has_the_defaults_and_writes_nothing(self) -> None:
        store = DictStore()
        kept = Persisted(store, RECORD)
        assert (kept.restored, kept.values(), store.puts) == (
            False, {"request_id": None, "holding": "none"}, 0)

    def test_each_change_is_one_value_with_its_version(self) -> None:
        """All fields go under one key, so one change is one transaction."""
        store = DictStore()
        kept = Persisted(store, RECORD)
        assert kept.set(request_id=7, holding="dirty")
        assert store.values == {"test.mission": {"version": 2, "values": {
            "request_id": 7, "holding": "dirty"}}}
        assert store.puts == 1

    def test_setting_the_same_values_writes_nothing(self) -> None:
        store = DictStore()
        kept = Persisted(store, RECORD)
        kept.set(request_id=7)
        assert not kept.set(request_id=7)
        assert store.puts == 1

    def test_an_undeclared_field_is_refused_and_nothing_changes(self) -> None:
        kept = Persisted(DictStore(), RECORD)
        with pytest.raises(KeyError, match=r"test\.mission: no such fields"):
            kept.set(pose=[1, 2])
        with pytest.raises(ValueError, match=r"test\.mission: value is not JSON-able"):
            kept.set(holding=object())
        assert kept.values() == dict(RECORD.fields)

    async def test_update_returns_once_the_change_is_durable(self) -> None:
        store = DictStore()
        kept = Persisted(store, RECORD)
        assert await kept.update(holding="clean")
        assert not await kept.update(holding="clean")
        assert store.flushes == 1

    def test_another_version_is_forgotten_without_a_migration(self) -> None:
        store = DictStore({"test.mission": {"version": 1, "values": {"holding": "dirty"}}})
        kept = Persisted(store, RECORD)
        assert (kept.restored, kept["holding"]) == (False, "none")

    def test_a_migration_turns_old_values_into_new(self) -> None:
        def migrate(version: int, values: dict[str, Any]) -> dict[str, Any] | None:
            return {"holding": values["load"]} if version == 1 else None

        record = MissionRecord("test.mission", 2, RECORD.fields, migrate)
        store = DictStore({"test.mission": {"version": 1, "values": {"load": "dirty"}}})
        kept = Persisted(store, record)
        assert (kept.restored, kept["holding"]) == (True, "dirty")

    @pytest.mark.parametrize("stored", ["junk", {"version": "2", "values": {}}, [1, 2],
                                        {"version": 2, "values": "x"}])
    def test_an_unreadable_value_gives_the_defaults(self, stored: Any) -> None:
        kept = Persisted(DictStore({"test.mission": stored}), RECORD)
        assert (kept.restored, kept.values()) == (False, dict(RECORD.fields))

    @given(st.lists(st.tuples(st.sampled_from(["request_id", "holding"]),
                              st.none() | st.integers() | st.text(max_size=5)), max_size=20))
    def test_a_restart_restores_the_last_value_of_every_field(
            self, changes: list[tuple[str, Any]]) -> None:
        """Whatever the sequence of changes, a new Persisted on the same store has the values
        the old one had last."""
        store = DictStore()
        kept = Persisted(store, RECORD)
        for name, value in changes:
            kept.set(**{name: value})
        assert Persisted(store, RECORD).values() == kept.values()


class TestContext:
    def test_a_record_is_restored_once_and_announced(self) -> None:
        events: list[tuple[str, dict[str, Any]]] = []
        store = DictStore({"test.mission": {"version": 2, "values": {"request_id": 3}}})
        ctx = RobotContext(Devices(), None, store, clock,  # type: ignore[arg-type]
                           lambda kind, **f: events.append((kind, f)))
        kept = ctx.persisted(RECORD)
        assert ctx.persisted(RECORD) is kept
        assert events == [("persist.restored", {"key": "test.mission", "values": {
            "request_id": 3, "holding": "none"}})]

    def test_two_different_declarations_of_one_key_are_refused(self) -> None:
        ctx = RobotContext(Devices(), None, DictStore(), clock,  # type: ignore[arg-type]
                           lambda kind, **f: None)
        ctx.persisted(RECORD)
        with pytest.raises(ValueError, match="declared twice"):
            ctx.persisted(MissionRecord("test.mission", 3, {}))


class TestEStopLatch:
    async def test_set_is_durable_and_keeps_the_first_cause(self) -> None:
        store = DictStore()
        latch = EStopLatch(store, clock)
        assert await latch.set("fleet", "the fleet server's EmergencyStop")
        assert latch.only_from("fleet")
        assert await latch.set("robotctl", "button")
        assert store.values[LATCH_KEY] == {"source": "fleet", "reason":
                                           "the fleet server's EmergencyStop",
                                           "at": "2026-01-01T12:00:00+00:00",
                                           "also": ["robotctl"]}
        assert not latch.only_from("fleet")
        assert store.flushes == 2

    async def test_clear_is_durable(self) -> None:
        store = DictStore()
        latch = EStopLatch(store, clock)
        await latch.set("robotctl", "x")
        assert await latch.clear(by="resume")
        assert (latch.latched, LATCH_KEY in store.values, store.flushes) == (False, False, 2)

    async def test_a_failing_disk_is_counted_not_raised(self) -> None:
        store = DictStore()
        store.fail = True
        latch = EStopLatch(store, clock)
        assert not await latch.set("robotctl", "x")
        assert latch.failures == 1
        assert latch.latched, "the robot still knows it is latched while it runs"
