"""The cabinet robot's scenarios end as issue 18 says: a closed door is driven round, a sealed
cabinet fails the mission naming it (exit 1, wheels stopped), and status shows the mission."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import pytest

from behaviours.profiles.cabinet.profile import CabinetProfile
from sim.runner import run_sim


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


SCENARIOS = Path(__file__).parents[2] / "sim" / "robots" / "cabinet" / "scenarios"


@pytest.mark.slow
def test_nearest_order_and_skip_act(tmp_path: Path) -> None:
    """order = nearest visits c1 before c3 (listed c3 first); on_unreachable = skip reports the
    sealed c2 as skipped and the mission still ends idle."""
    tasks = {"behaviour": {"order": "nearest", "on_unreachable": "skip"},
             "tasks": [{"cabinet": "c3"}, {"cabinet": "c2"}, {"cabinet": "c1"}]}
    (tmp_path / "tasks.json").write_text(json.dumps(tasks))
    site = SCENARIOS / "cabinet" / "site.json"
    scenario = tmp_path / "order.toml"
    scenario.write_text(f"""
[scenario]
name = "order"
profile = "cabinet"
[config.cabinet]
map_file = "{site}"
task_file = "{tmp_path / 'tasks.json'}"
fit_fov_deg = 120.0
fit_min_view_deg = 250.0
fit_min_score = 0.75
max_link_resets = 0
[world]
site_map = "{site}"
[robot]
x_m = 3.4
y_m = 3.2
heading_deg = 90
[[script]]
at_s = 0.0
action = "door.close"
name = "ab"
[[script]]
at_s = 0.0
action = "door.close"
name = "b-hall"
[success]
time_limit_s = 900
final_state = "idle"
cabinets_in_order = ["c1", "c3"]
""")
    out = tmp_path / "out"
    code = run_sim(argparse.Namespace(scenario=str(scenario), seed=2, report=str(out),
                                      quiet=True))
    events = _events(out)
    assert code == 0, events[-1]
    skipped = [e["cabinet"] for e in events if e["kind"] == "task.skipped"]
    assert skipped == ["c2"]


def test_robotctl_status_shows_the_mission_rows() -> None:
    """A status with ``mission`` gets one ``mission.<key>`` row per key."""
    from robotd.ctl import render

    text = render("status", {"robot": "r", "mission": {"path": ["a", "b"],
                                                        "broken_links": [["a", "c"]]}})
    assert 'mission.path          ["a", "b"]' in text
    assert "mission.broken_links" in text


@pytest.mark.slow
def test_the_mission_runs_on_a_map_the_robot_made(tmp_path: Path) -> None:
    """cabinet-made: the map is robotd map's PGM (no wall list); the fit finds the pose on it
    and the four cabinets are reached in order, each within 10 cm."""
    code = run_sim(argparse.Namespace(scenario="cabinet-made", seed=1, report=str(tmp_path),
                                      quiet=True))
    assert code == 0
    events = _events(tmp_path)
    perceived = next(e for e in events if e["kind"] == "init.perceptor")
    assert isinstance(perceived["walls"], int) and perceived["walls"] > 50  # outlines, not 18
    assert [e["cabinet"] for e in events if e["kind"] == "cabinet.arrived"] == [
        "c2", "c4", "c3", "c1"]
    result = events[-1]
    assert result["kind"] == "result" and result["ok"] is True
