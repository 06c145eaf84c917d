"""``laundry-busy`` (issue 27): the laundry site as it really runs. Three robots on one painted
loop, six customers whose requests overlap, laundry-1 killed for 90 s with laundry aboard, the
staff slow to unload once. The run passes its own success conditions (every request ends as
the seed says, no loaded departure, one robot on the line, no collision, the dead robot's alert
resolved by the staff); these tests read its events for how it got there."""

from __future__ import annotations

import json
from typing import Any

import pytest

from robotd.cli import main


@pytest.fixture(scope="module")
def events(tmp_path_factory: pytest.TempPathFactory) -> list[dict[str, Any]]:
    out = tmp_path_factory.mktemp("busy") / "out"
    assert main(["sim", "laundry-busy", "--quiet", "--report", str(out)]) == 0
    return [json.loads(line) for line in (out / "events.jsonl").read_text().splitlines()]


def kinds(events: list[dict[str, Any]], kind: str) -> list[dict[str, Any]]:
    return [e for e in events if e["kind"] == kind]


class TestTheBusySite:
    def test_no_robot_leaves_base_with_a_load_unless_it_delivers(self, events):
        departures = kinds(events, "site.left_base")
        assert len(departures) >= 8
        assert all(d["payload_kg"] == 0.0 or d["delivering"] for d in departures)
        assert not kinds(events, "site.line_shared")

    def test_the_dead_robots_alert_is_resolved_by_the_staff_with_the_laundry_at_base(
            self, events):
        [resolved] = kinds(events, "staff.alert_resolved")
        assert (resolved["robot"], resolved["laundry_at"], resolved["code"]) == (
            "laundry-1", "base", 200)
        [kill] = [s for s in kinds(events, "script") if s.get("action") == "robot.kill"]
        assert kill["robot"] == "laundry-1"

    def test_robots_queue_at_base_and_pull_up_without_a_blocked_fault(self, events):
        """A robot back behind another waits in mission.queued, then arrives at the base
        beacon once the one ahead has gone; no 'blocked' alert is raised for the queue."""
        queued = [t for t in kinds(events, "transition") if t["dst"] == "mission.queued"]
        assert queued
        pulled_up = [t for t in kinds(events, "transition")
                     if t["src"] == "mission.queued" and t["dst"] == "mission.at_base"]
        assert pulled_up
        faults = [a for a in kinds(events, "staff.alert_acknowledged")
                  if a["alert_kind"] == "robot.fault"]
        assert faults == []

    def test_a_washed_delivery_waits_for_a_robot_and_then_goes(self, events):
        done = kinds(events, "staff.washing_done")
        loaded = kinds(events, "staff.loaded_clean")
        assert len(done) == len(loaded) == 4
