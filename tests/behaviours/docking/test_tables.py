"""The docking tables held beside the seed: every state and every arrow of its diagrams."""

from __future__ import annotations

from typing import Any

import pytest

from behaviours.docking.machine_part import AttemptCallbacks
from behaviours.docking.tables import DOCKING_TRANSITIONS, docking_states
from behaviours.machine import MachineModel
from behaviours.machine_part import MachinePart
from behaviours.machine_tables import CORE_TRANSITIONS, callback_names, root_states

SEED_STATES = {
    # Section 1: the whole process.
    "DockingMode": "docking",
    "Phase1_Search": "docking.search",
    "WallFollow": "docking.search.wall_follow",
    "ForceFieldDetect": "docking.search.force_field_detect",
    "DirectionTurn": "docking.search.direction_turn",
    "Phase2_Approach": "docking.approach",
    "FrontBeamDetect": "docking.approach.front_beam_detect",
    "LeftOnly": "docking.approach.left_only",
    "RightOnly": "docking.approach.right_only",
    "MicroRight": "docking.approach.micro_right",
    "MicroLeft": "docking.approach.micro_left",
    "BothBeams": "docking.approach.both_beams",
    "OverlapZone": "docking.approach.overlap_zone",
    "Phase3_Align": "docking.align",
    "CenterBeamSearch": "docking.align.center_beam_search",
    "FineAlign": "docking.align.fine_align",
    "SignalCompare": "docking.align.signal_compare",
    "LeftStronger": "docking.align.left_stronger",
    "RightStronger": "docking.align.right_stronger",
    "MicroAdjustR": "docking.align.micro_adjust_r",
    "MicroAdjustL": "docking.align.micro_adjust_l",
    "Balanced": "docking.align.balanced",
    "Phase4_Dock": "docking.dock",
    "SlowForward": "docking.dock.slow_forward",
    "ContactCheck": "docking.dock.contact_check",
    "AlignCheck": "docking.dock.align_check",
    "VoltageDetect": "docking.dock.voltage_detect",
    "MotorStop": "docking.dock.motor_stop",
    "Retry": "docking.dock.retry",
    "Charging": "docking.charging",
    # Section 2: the position cases.
    "PositionAnalysis": "docking.position",
    "ScanBeams": "docking.position.scan_beams",
    "LeftApproach": "docking.position.left_approach",
    "TurnLeft_LA": "docking.position.left_approach.turn_left",
    "ForwardL": "docking.position.left_approach.forward_l",
    "FrontR_Entry": "docking.position.left_approach.front_r_entry",
    "OverlapL": "docking.position.left_approach.overlap_l",
    "RightApproach": "docking.position.right_approach",
    "TurnRight_RA": "docking.position.right_approach.turn_right",
    "ForwardR": "docking.position.right_approach.forward_r",
    "FrontL_Entry": "docking.position.right_approach.front_l_entry",
    "OverlapR": "docking.position.right_approach.overlap_r",
    "FrontApproach": "docking.position.front_approach",
    "CheckSkew": "docking.position.front_approach.check_skew",
    "SkewLeft": "docking.position.front_approach.skew_left",
    "SkewRight": "docking.position.front_approach.skew_right",
    "CorrectRight": "docking.position.front_approach.correct_right",
    "CorrectLeft": "docking.position.front_approach.correct_left",
    "Centered": "docking.position.front_approach.centered",
    "RearApproach": "docking.position.rear_approach",
    "Turn180": "docking.position.rear_approach.turn180",
    "FrontNow": "docking.position.rear_approach.front_now",
    "CenterAlign": "docking.align",
    "Docking": "docking.dock",
    # Section 5: after docking.
    "EMPTY_SEQ": "docking.emptying",
    "DOOR_OPEN": "docking.emptying.door_open",
    "VACUUM_ON": "docking.emptying.vacuum_on",
    "WAIT_EMPTY": "docking.emptying.wait_empty",
    "VACUUM_OFF": "docking.emptying.vacuum_off",
    "DOOR_CLOSE": "docking.emptying.door_close",
    "STANDBY": "docking.standby",
    "UNDOCK": "docking.undock",
}
"""The seed's state -> our dotted path (snake_case, nested)."""

SEED_ARROWS = [
    # Section 1 (a phase's "[*]" end is the arrow to the next phase).
    ("docking", "docking.search.wall_follow"),
    ("docking.search.wall_follow", "docking.search.force_field_detect"),
    ("docking.search.force_field_detect", "docking.search.direction_turn"),
    ("docking.search.direction_turn", "docking.position"),
    ("docking.approach.front_beam_detect", "docking.approach.left_only"),
    ("docking.approach.front_beam_detect", "docking.approach.right_only"),
    ("docking.approach.front_beam_detect", "docking.approach.both_beams"),
    ("docking.approach.left_only", "docking.approach.micro_right"),
    ("docking.approach.right_only", "docking.approach.micro_left"),
    ("docking.approach.micro_right", "docking.approach.front_beam_detect"),
    ("docking.approach.micro_left", "docking.approach.front_beam_detect"),
    ("docking.approach.both_beams", "docking.approach.overlap_zone"),
    ("docking.approach.overlap_zone", "docking.align"),
    ("docking.align.center_beam_search", "docking.align.fine_align"),
    ("docking.align.fine_align", "docking.align.signal_compare"),
    ("docking.align.signal_compare", "docking.align.left_stronger"),
    ("docking.align.signal_compare", "docking.align.right_stronger"),
    ("docking.align.signal_compare", "docking.align.balanced"),
    ("docking.align.left_stronger", "docking.align.micro_adjust_r"),
    ("docking.align.right_stronger", "docking.align.micro_adjust_l"),
    ("docking.align.micro_adjust_r", "docking.align.signal_compare"),
    ("docking.align.micro_adjust_l", "docking.align.signal_compare"),
    ("docking.align.balanced", "docking.dock"),
    ("docking.dock.slow_forward", "docking.dock.contact_check"),
    ("docking.dock.contact_check", "docking.dock.voltage_detect"),
    ("docking.dock.contact_check", "docking.dock.align_check"),
    ("docking.dock.align_check", "docking.dock.slow_forward"),
    ("docking.dock.align_check", "docking.align"),
    ("docking.dock.voltage_detect", "docking.dock.motor_stop"),
    ("docking.dock.voltage_detect", "docking.dock.retry"),
    ("docking.dock.retry", "docking.align"),
    ("docking.dock.motor_stop", "docking.charging"),
    # Section 2.
    ("docking.position.scan_beams", "docking.position.left_approach"),
    ("docking.position.scan_beams", "docking.position.right_approach"),
    ("docking.position.scan_beams", "docking.position.front_approach"),
    ("docking.position.scan_beams", "docking.position.rear_approach"),
    ("docking.position.left_approach.turn_left", "docking.position.left_approach.forward_l"),
    ("docking.position.left_approach.forward_l", "docking.position.left_approach.front_r_entry"),
    ("docking.position.left_approach.front_r_entry",
     "docking.position.left_approach.overlap_l"),
    ("docking.position.right_approach.turn_right", "docking.position.right_approach.forward_r"),
    ("docking.position.right_approach.forward_r",
     "docking.position.right_approach.front_l_entry"),
    ("docking.position.right_approach.front_l_entry",
     "docking.position.right_approach.overlap_r"),
    ("docking.position.front_approach.check_skew", "docking.position.front_approach.skew_left"),
    ("docking.position.front_approach.check_skew",
     "docking.position.front_approach.skew_right"),
    ("docking.position.front_approach.check_skew", "docking.position.front_approach.centered"),
    ("docking.position.front_approach.skew_left",
     "docking.position.front_approach.correct_right"),
    ("docking.position.front_approach.skew_right",
     "docking.position.front_approach.correct_left"),
    ("docking.position.front_approach.correct_right",
     "docking.position.front_approach.check_skew"),
    ("docking.position.front_approach.correct_left",
     "docking.position.front_approach.check_skew"),
    ("docking.position.rear_approach.turn180", "docking.position.rear_approach.front_now"),
    ("docking.position.rear_approach.front_now", "docking.position.front_approach"),
    # Section 4: fallback to wall following.
    ("docking.dock.voltage_detect", "docking.search"),
    ("docking.approach", "docking.search"),
    # Section 5.
    ("docking.charging", "docking.emptying"),
    ("docking.emptying.door_open", "docking.emptying.vacuum_on"),
    ("docking.emptying.vacuum_on", "docking.emptying.wait_empty"),
    ("docking.emptying.wait_empty", "docking.emptying.vacuum_off"),
    ("docking.emptying.vacuum_off", "docking.emptying.door_close"),
    ("docking.emptying.door_close", "docking.charging"),
    ("docking.charging", "docking.standby"),
    ("docking.standby", "docking.undock"),
    ("docking.undock", "mission"),
]
"""The seed's arrows (our paths): each must be a transition of the table."""


def _paths(states: list[Any], prefix: str) -> set[str]:
    out: set[str] = set()
    for item in states:
        name = item if isinstance(item, str) else item["name"]
        path = f"{prefix}.{name}"
        out.add(path)
        if isinstance(item, dict):
            out |= _paths(item.get("children", []), path)
    return out


def _arrows() -> set[tuple[str, str]]:
    pairs: set[tuple[str, str]] = set()
    for t in DOCKING_TRANSITIONS:
        sources = t["source"] if isinstance(t["source"], list) else [t["source"]]
        pairs |= {(s, t["dest"]) for s in sources}
    return pairs


class TestSeedChecklist:
    @pytest.mark.parametrize(("seed", "path"), sorted(SEED_STATES.items()))
    def test_every_state_of_the_seed_is_in_the_table(self, seed: str, path: str) -> None:
        """Each state of the seed's diagrams has its snake_case path under ``docking``."""
        assert path in _paths(docking_states(), "docking") | {"docking"}, seed

    @pytest.mark.parametrize(("source", "dest"), SEED_ARROWS)
    def test_every_arrow_of_the_seed_is_a_transition(self, source: str, dest: str) -> None:
        """Each arrow (and each loop) of the seed is a transition of its own."""
        if source == "docking":
            states = docking_states()
            first = states[0]
            assert isinstance(first, dict) and first["name"] == "search"
            assert first["initial"] == "wall_follow"
            return
        assert (source, dest) in _arrows()

    def test_every_destination_is_a_state(self) -> None:
        """No transition leads to a state that does not exist."""
        known = _paths(docking_states(), "docking") | {"docking", "mission", "recovery"}
        assert {d for _, d in _arrows()} <= known

    def test_every_callback_named_exists_on_the_model_or_the_part(self) -> None:
        """Every callback and condition of the core tables is a model method, and every one
        the docking part's tables add is a method of its callbacks."""
        core = callback_names(root_states([]), CORE_TRANSITIONS)
        assert sorted(n for n in core if not hasattr(MachineModel, n)) == []
        part = MachinePart("docking", "docking",
                           {"initial": "search", "children": docking_states(),
                            "on_enter": "start_docking"}, tuple(DOCKING_TRANSITIONS))
        names = callback_names(root_states([], (part,)), DOCKING_TRANSITIONS) - core
        assert {"count_dock_failure", "may_retry_docking", "may_fall_back"} <= names
        assert sorted(n for n in names if not hasattr(AttemptCallbacks, n)) == []


class TestSectionFour:
    @pytest.mark.parametrize("trigger", ["align_lost", "contact_failed", "voltage_abnormal",
                                         "signal_lost", "timeout"])
    def test_each_error_retries_falls_back_or_gives_up_in_that_order(self, trigger: str
                                                                     ) -> None:
        """Three rows per error: retry (counted), fallback to wall following, recovery."""
        rows = [t for t in DOCKING_TRANSITIONS if t["trigger"] == trigger
                and t.get("dest") != "docking.emptying.vacuum_off"
                and t["source"] not in ("docking.emptying", "docking.undock")]
        assert [r.get("conditions") for r in rows] == ["may_retry_docking", "may_fall_back",
                                                       None]
        assert rows[0]["prepare"] == "count_dock_failure"
        assert rows[1]["dest"] == "docking.search"  # its initial state: wall_follow
        assert rows[2]["dest"] == "recovery"
