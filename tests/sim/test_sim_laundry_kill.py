"""The laundry robot's daemon killed mid-mission in the simulator and started again on the same
state directory: it knows what it holds and the request completes (``robot.kill``)."""

from __future__ import annotations

import json
import tempfile
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from kill_scenario import write_kill_scenario

from robotd.cli import main

HOLDS = {"LaundryLoaded": "dirty", "FinishedWashingGoingToRoom": "clean",
         "FinishedWashingArrivedAtRoom": "clean"}


def run_kill(directory: Path, **kill: Any) -> tuple[int, list[dict[str, Any]]]:
    scenario = write_kill_scenario(directory, **kill)
    out = directory / "out"
    code = main(["sim", str(scenario), "--quiet", "--seed", "21", "--report", str(out)])
    events = [json.loads(line) for line in (out / "events.jsonl").read_text().splitlines()]
    return code, events


def kinds(events: list[dict[str, Any]], kind: str) -> list[dict[str, Any]]:
    return [e for e in events if e["kind"] == kind]


def statuses(events: list[dict[str, Any]]) -> list[str]:
    return [e["status"] for e in kinds(events, "request")]


LIFECYCLE = ["Accepted", "ArrivedAtRoom", "LaundryLoaded", "Washing",
             "FinishedWashingGoingToRoom", "FinishedWashingArrivedAtRoom",
             "FinishedWashingGoingToBase", "Completed"]


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> tuple[int, list[dict[str, Any]]]:
    return run_kill(tmp_path_factory.mktemp("kill"), when_state="mission.to_base",
                    delay_s=3.0, restart_after_s=2.0)


class TestKilledOnTheWayToBase:
    def test_the_restarted_robot_holds_the_dirty_laundry_of_request_1(
            self, run: tuple[int, list[dict[str, Any]]]) -> None:
        """Restored before it left boot: dirty laundry of request 1, last at room 101, going
        to the base; the server's first answer agrees."""
        _, events = run
        restored = kinds(events, "laundry.restored")
        assert len(restored) == 1
        assert {k: restored[0][k] for k in ("holding", "holding_request_id", "request_id",
                                            "last_room", "target_room")} == {
            "holding": "dirty", "holding_request_id": 1, "request_id": 1,
            "last_room": "101", "target_room": "base"}
        reconciled = kinds(events, "laundry.reconciled")
        assert {k: reconciled[0][k] for k in ("agrees", "server_status", "holding")} == {
            "agrees": True, "server_status": "LaundryLoaded", "holding": "dirty"}
        boot = [e for e in events if e["kind"] == "transition" and e["src"] == "boot"]
        assert restored[0]["t"] >= boot[1]["t"]
        persisted = kinds(events, "persist.restored")
        assert persisted[0]["t"] <= boot[1]["t"], "restored before the machine left boot"

    def test_it_goes_on_to_the_base_and_the_request_completes(
            self, run: tuple[int, list[dict[str, Any]]]) -> None:
        code, events = run
        assert code == 0, events[-1]["reasons"]
        assert statuses(events) == LIFECYCLE
        assert [e["action"] for e in kinds(events, "script")] == ["robot.kill", "robot.restart"]
        assert not kinds(events, "laundry.unclaimed")


# Seed 21's mission without a kill (s after the robot is idle): going to room 101 5-19, at
# the room 19-29, dirty laundry to the base 29-83, washing 83-115, clean laundry to the room
# 115-132, at the room 132-140, back to the base 140-194. Each example kills inside one.
PHASES_S = ((5.5, 19.0), (19.5, 29.0), (29.5, 82.0), (84.0, 114.0), (115.5, 131.0),
            (132.5, 139.5), (140.5, 192.0))


@settings(max_examples=4, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(kill_at_s=st.sampled_from(PHASES_S).flatmap(lambda p: st.floats(*p)),
       down_s=st.floats(min_value=0.2, max_value=5.0))
@example(kill_at_s=55.0, down_s=1.0)    # dirty laundry aboard
@example(kill_at_s=125.0, down_s=3.0)   # clean laundry aboard
def test_killed_at_any_moment_it_knows_what_it_holds_and_nothing_is_lost(
        kill_at_s: float, down_s: float) -> None:
    """Killed at a random moment of the mission and restarted: what it restored agrees with
    what the server's status says it carries, no laundry is unclaimed, and the request goes
    through its whole lifecycle to Completed and paid."""
    with tempfile.TemporaryDirectory(prefix="rd-kill-") as name:
        code, events = run_kill(Path(name), when_state="idle", delay_s=kill_at_s,
                                restart_after_s=down_s)
    assert code == 0, events[-1]["reasons"]
    assert statuses(events) == LIFECYCLE
    assert not kinds(events, "laundry.unclaimed")
    for restored in kinds(events, "laundry.restored"):
        # What it remembered agrees with the last status it had been told.
        assert restored["holding"] == HOLDS.get(restored["request_status"], "none"), restored
    for reconciled in kinds(events, "laundry.reconciled"):
        # Once the server has answered, it holds what the request's status says.
        if reconciled["server_request_id"] is not None:
            assert reconciled["holding"] == HOLDS.get(reconciled["server_status"], "none")
