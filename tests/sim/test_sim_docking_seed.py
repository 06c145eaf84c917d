"""Issue 28: the docking seed's branches that no scenario reached before, each in a built-in
scenario run here: a start out of the beams (wall following first, then the force field),
L != R and the align check, a virtual wall while cleaning and behind the undock."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from robotd.cli import main

Run = tuple[int, list[dict[str, Any]]]


def _run(name: str, out: Path) -> Run:
    code = main(["sim", name, "--quiet", "--report", str(out)])
    events = [json.loads(line) for line in (out / "events.jsonl").read_text().splitlines()]
    return code, events


def _states(events: list[dict[str, Any]]) -> list[str]:
    return [e["dst"] for e in events if e["kind"] == "transition"]


def _first(events: list[dict[str, Any]], kind: str, **fields: Any) -> dict[str, Any]:
    return next(e for e in events if e["kind"] == kind
                and all(e.get(k) == v for k, v in fields.items()))


@pytest.fixture(scope="module")
def far(tmp_path_factory: pytest.TempPathFactory) -> Run:
    return _run("docking-far", tmp_path_factory.mktemp("far"))


class TestDockingFar:
    def test_it_passes(self, far: Run) -> None:
        assert far[0] == 0

    def test_it_wall_follows_out_of_range_then_homes_in_to_the_force_field(self,
                                                                        far: Run) -> None:
        """Out of every beam's range the search follows walls a while; a far beam is not
        the force field: the robot homes in until the force-field code is seen."""
        _, events = far
        go = _first(events, "transition", dst="docking.search.wall_follow")
        beam = _first(events, "transition", trigger="beam_detected")
        assert beam["t"] - go["t"] > 10.0 and beam["x_m"] < go["x_m"] - 2.0
        home = _first(events, "dock.home_in")
        field = _first(events, "dock.field")
        assert home["field"] is True
        assert any("force_field" in beams for beams in field["beams"].values())
        assert _states(events)[-1] == "docking.charging"


@pytest.fixture(scope="module")
def align(tmp_path_factory: pytest.TempPathFactory) -> Run:
    return _run("docking-align", tmp_path_factory.mktemp("align"))


class TestDockingAlign:
    def test_it_passes(self, align: Run) -> None:
        assert align[0] == 0

    def test_l_greater_than_r_turns_right_until_balanced(self, align: Run) -> None:
        _, events = align
        states = _states(events)
        i = states.index("docking.align.left_stronger")
        assert states[i + 1] == "docking.align.micro_adjust_r"
        assert states[i + 2] == "docking.align.signal_compare"
        signal = _first(events, "dock.signal", case="left_stronger")
        assert signal["left"] > signal["right"]

    def test_a_bump_beside_the_pads_is_align_lost_then_realigned(self, align: Run) -> None:
        _, events = align
        states = _states(events)
        i = states.index("docking.dock.align_check")
        assert states[i - 1] == "docking.dock.contact_check"
        assert states[i + 1] == "docking.align.center_beam_search"
        results = [(e["error_code"], e.get("error")) for e in events
                   if e["kind"] == "dock.result"]
        assert results == [(905, "align_lost"), (0, None)]


@pytest.fixture(scope="module")
def wall(tmp_path_factory: pytest.TempPathFactory) -> Run:
    return _run("docking-virtual-wall", tmp_path_factory.mktemp("wall"))


class TestDockingVirtualWall:
    def test_it_passes(self, wall: Run) -> None:
        assert wall[0] == 0

    def test_cleaning_turns_away_before_crossing_the_beam(self, wall: Run) -> None:
        """The beam runs from (3.2, 0.1) towards (1.0, 2.0): met while cleaning, the robot
        turns away on the side it came from (above the beam's line)."""
        _, events = wall
        turn = _first(events, "clean.virtual_wall")
        assert turn["t"] < _first(events, "transition", trigger="go_dock")["t"]
        # the side of the beam's line the robot started on (above it)
        dx, dy = turn["x_m"] - 3.2, turn["y_m"] - 0.1
        assert -0.774 * dy - 0.633 * dx < 0.1

    def test_undocking_stops_short_at_the_virtual_wall_behind(self, wall: Run) -> None:
        _, events = wall
        guard = _first(events, "dock.reverse_guard", during="undock")
        assert guard["reason"] == "virtual wall behind"
        assert 0.1 < guard["backed_m"] < guard["wanted_m"]
        undocked = _first(events, "transition", trigger="undocked")
        assert undocked["dst"] == "mission.cleaning"

    def test_standby_waited_for_the_schedule(self, wall: Run) -> None:
        _, events = wall
        nxt = _first(events, "clean.next")
        assert nxt["by"] == "schedule" and nxt["at"] == "2026-01-01T00:04:00+00:00"
        assert _first(events, "transition", trigger="clean_scheduled")["t"] == pytest.approx(
            240.0, abs=0.01)
