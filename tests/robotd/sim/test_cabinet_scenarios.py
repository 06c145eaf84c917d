"""The cabinet robot's scenarios end as issue 18 says: a closed door is driven round, a sealed
cabinet fails the mission naming it (exit 1, wheels stopped), and status shows the mission."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import pytest

from behaviours.profiles.cabinet.profile import CabinetProfile
from robotd.sim.runner import run_sim


def _events(out: Path) -> list[dict[str, object]]:
    return [json.loads(line) for line in (out / "events.jsonl").read_text().splitlines()]


@pytest.mark.slow
def test_a_closed_door_is_driven_round(tmp_path: Path) -> None:
    """cabinet-door: link.closed on the door's link, a new path through the hall, arrival."""
    code = run_sim(argparse.Namespace(scenario="cabinet-door", seed=1, report=str(tmp_path),
                                      quiet=True))
    assert code == 0
    events = _events(tmp_path)
    closed = [e for e in events if e["kind"] == "link.closed"]
    assert closed[0]["a"] == "door:ab:a" and closed[0]["b"] == "door:ab:b"
    paths = [e["nodes"] for e in events if e["kind"] == "path.planned"]
    assert "door:b-hall:b" in paths[-1]
    assert [e["cabinet"] for e in events if e["kind"] == "cabinet.arrived"] == ["c2"]


@pytest.mark.slow
def test_a_sealed_cabinet_fails_the_mission_naming_it(tmp_path: Path) -> None:
    """cabinet-sealed: exit 1, mission.failed naming c2 as the expected reason."""
    code = run_sim(argparse.Namespace(scenario="cabinet-sealed", seed=1, report=str(tmp_path),
                                      quiet=True))
    assert code == 1
    result = _events(tmp_path)[-1]
    assert result["kind"] == "result"
    reasons = result["reasons"]
    assert isinstance(reasons, list) and len(reasons) == 1
    assert reasons[0].startswith("mission.failed as expected: cabinet c2:")


def test_status_before_the_map_is_read_is_empty() -> None:
    """A profile that has not started has no mission to show (and no links to list)."""
    profile = CabinetProfile()
    assert profile.mission_status() == {}
    assert profile.status() == {}
