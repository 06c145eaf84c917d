"""``robotd sim docking`` and its variants: the vacuum's whole cycle, each position case, the
contacts' fault (retries, fallback, recovery), the beams switched off, a person in the beam."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from robotd.cli import main

SCENARIOS = Path(__file__).resolve().parents[2] / "sim" / "robots" / "vacuum" / "scenarios"


def _events(report: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in (report / "events.jsonl").read_text().splitlines()]


def _states(events: list[dict[str, Any]]) -> list[str]:
    return [e["dst"] for e in events if e["kind"] == "transition"]


def _run(args: list[str], out: Path) -> tuple[int, list[dict[str, Any]]]:
    code = main(["sim", *args, "--quiet", "--report", str(out)])
    return code, _events(out)


def _variant(tmp: Path, base: str, name: str, extra: str, success: str) -> str:
    """A built-in scenario with more script steps and other success conditions."""
    text = (SCENARIOS / f"{base}.toml").read_text()
    head, _, _ = text.partition("[success]")
    path = tmp / f"{name}.toml"
    path.write_text(head.replace(f'name = "{base}"', f'name = "{name}"') + extra
                    + "\n[success]\n" + success)
    return str(path)


@pytest.fixture(scope="module")
def cycle(tmp_path_factory: pytest.TempPathFactory) -> tuple[int, list[dict[str, Any]]]:
    return _run(["docking"], tmp_path_factory.mktemp("docking"))


class TestWholeCycle:
    def test_exits_0_with_the_report(self, cycle: tuple[int, list[dict[str, Any]]]) -> None:
        code, events = cycle
        assert code == 0
        assert events[-1]["kind"] == "result" and events[-1]["ok"] is True

    def test_the_seed_cycle_in_order(self, cycle: tuple[int, list[dict[str, Any]]]) -> None:
        """cleaning -> battery < 20 % -> search, approach, align, dock -> charging ->
        emptying -> standby -> undock -> cleaning again, with the seed's sub-states."""
        _, events = cycle
        states = _states(events)
        milestones = ["mission.cleaning", "mission.battery_check", "docking.search.wall_follow",
                      "docking.position.scan_beams", "docking.approach.overlap_zone",
                      "docking.align.signal_compare", "docking.dock.slow_forward",
                      "docking.dock.voltage_detect", "docking.charging",
                      "docking.emptying.wait_empty", "docking.charging", "docking.standby",
                      "docking.undock", "mission.cleaning"]
        at = 0
        for state in states:
            if at < len(milestones) and state == milestones[at]:
                at += 1
        assert at == len(milestones), f"stopped before {milestones[at:at + 1]}"
        low = next(e for e in events if e["kind"] == "clean.battery_low")
        assert low["battery_pct"] < low["threshold_pct"] == 20.0

    def test_one_successful_attempt_with_its_time(
            self, cycle: tuple[int, list[dict[str, Any]]]) -> None:
        _, events = cycle
        results = [e for e in events if e["kind"] == "dock.result"]
        assert results[-1]["success"] is True and results[-1]["error_code"] == 0
        assert results[-1]["time_s"] > 0

    def test_the_station_empties_the_bin_with_the_door_open(
            self, cycle: tuple[int, list[dict[str, Any]]]) -> None:
        _, events = cycle
        emptied = next(e for e in events if e["kind"] == "dock.emptied")
        assert emptied["bin_pct"] <= 5.0


class TestPositionCases:
    @pytest.mark.parametrize(("scenario", "case", "turn"), [
        ("docking-left", "left_approach", "turn_left"),
        ("docking-right", "right_approach", "turn_right"),
        ("docking-rear", "rear_approach", "turn180"),
    ])
    def test_each_case_is_taken_from_a_start_that_calls_for_it(
            self, tmp_path: Path, scenario: str, case: str, turn: str) -> None:
        """Far-R -> left approach, Far-L -> right approach, rear receiver -> turn180 -> front;
        each docks and charges."""
        code, events = _run([scenario], tmp_path)
        assert code == 0
        states = _states(events)
        scan = states.index("docking.position.scan_beams")
        assert states[scan + 1] == f"docking.position.{case}.{turn}"
        if case == "rear_approach":
            after = states[scan + 2:scan + 4]
            assert after == ["docking.position.rear_approach.front_now",
                             "docking.position.front_approach.check_skew"]
        assert states[-1] == "docking.charging"
        fig = events[-1]["figures"]["vac-1"]
        assert abs(fig["dock_lateral_cm"]) <= 1.5 and abs(fig["dock_heading_deg"]) <= 3


class TestFaults:
    def test_a_long_contacts_fault_retries_falls_back_twice_then_recovery(
            self, tmp_path: Path) -> None:
        """Three failed attempts with 906, the fallback to wall_follow, again, then recovery
        with a reason naming the voltage; motors stopped there."""
        path = _variant(tmp_path, "docking-rear", "contacts-long", """
[[script]]
at_s = 0.5
action = "dock.contacts_fault"
""", 'time_limit_s = 1500\nfinal_state = "recovery"\nno_collisions = false\n')
        # Seed 2: at seed 1 one of the nine approaches meets the station's body beside the
        # pads (a 905 align_lost, docking's own noise: ~1 attempt in 8 in the bench), which
        # is not what this test is about.
        code, events = _run([path, "--seed", "2"], tmp_path / "out")
        assert code == 0
        results = [e for e in events if e["kind"] == "dock.result"]
        assert [r["error_code"] for r in results] == [906] * 9
        assert [r["retries"] for r in results] == [1, 2, 3] * 3
        assert all("mV outside" in r["reason"] for r in results)
        fallbacks = [e for e in events if e["kind"] == "dock.fallback"]
        assert len(fallbacks) == 2
        states = _states(events)
        assert states.count("docking.search.wall_follow") >= 3
        gave_up = next(e for e in events if e["kind"] == "dock.gave_up")
        assert "6500 mV" in gave_up["reason"]
        assert states[-1] == "recovery"

    def test_a_short_contacts_fault_ends_charging(self, tmp_path: Path) -> None:
        path = _variant(tmp_path, "docking-rear", "contacts-short", """
[[script]]
at_s = 0.5
action = "dock.contacts_fault"
duration_s = 90
""", 'time_limit_s = 600\nfinal_state = "docking.charging"\nno_collisions = false\n')
        code, events = _run([path], tmp_path / "out")
        assert code == 0
        results = [e for e in events if e["kind"] == "dock.result"]
        assert results[0]["error_code"] == 906 and results[-1]["success"] is True

    def test_beams_off_during_alignment_loses_the_signal_and_search_restarts(
            self, tmp_path: Path) -> None:
        path = _variant(tmp_path, "docking-left", "beams-off", """
[[script]]
at_s = 36.0
action = "dock.beams_off"
duration_s = 8
""", 'time_limit_s = 600\nfinal_state = "docking.charging"\nno_collisions = false\n')
        code, events = _run([path], tmp_path / "out")
        assert code == 0
        lost = next(e for e in events if e["kind"] == "dock.result")
        assert lost["error"] == "signal_lost" and lost["error_code"] == 904
        assert lost["state"].startswith("docking.align")
        i = next(i for i, e in enumerate(events) if e is lost)
        after = next(e for e in events[i:] if e["kind"] == "transition")
        assert after["dst"] == "docking.search.wall_follow"

    def test_a_person_in_the_beam_blocks_it(self, tmp_path: Path) -> None:
        """Standing between the robot and the dock, a person shades every beam: the robot
        finds nothing to dock to until the person walks away."""
        text = (SCENARIOS / "docking-rear.toml").read_text()
        text = text.replace("[robot]\n", "people = [ { name = \"ann\", x_m = 0.9, y_m = 2.05, "
                            "radius_m = 0.25 } ]\n\n[robot]\n")
        text = text.replace("x_m = 0.6\n", "x_m = 1.6\n")  # beyond the person, facing away
        text = text.replace('name = "docking-rear"', 'name = "person"')
        head, _, _ = text.partition("[success]")
        path = tmp_path / "person.toml"
        path.write_text(head + """
[[script]]
at_s = 40.0
action = "person.remove"
name = "ann"

[success]
time_limit_s = 600
final_state = "docking.charging"
no_collisions = false
""")
        code, events = _run([str(path)], tmp_path / "out")
        assert code == 0
        docked = next(e for e in events if e["kind"] == "dock.result" and e["success"])
        assert docked["t"] > 40.0
        fields = [e for e in events if e["kind"] == "dock.field" and e["t"] < 40.0]
        assert all("front_left" not in beams for f in fields for beams in f["beams"].values())
