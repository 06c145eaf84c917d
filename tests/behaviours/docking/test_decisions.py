"""Each phase's decisions from beam and signal inputs (pure functions, then the phase steps
against doubles)."""

from __future__ import annotations

import math
from typing import Any

import pytest
from docking_doubles import Rig
from hypothesis import given
from hypothesis import strategies as st

from behaviours.docking import approach, contact, search
from behaviours.docking.align import signal_compare
from behaviours.docking.beams import BeamView, front_case, position_case, signal_case, skew_case
from behaviours.docking.config import DEFAULT_BEAM_ROLES
from hal.readings import DockContacts, DockIrReading, DockSignal
from sim import vclock


def view(**beams: tuple[str, ...]) -> BeamView:
    reading = DockIrReading(beams={r: frozenset(b) for r, b in beams.items()})
    return BeamView(reading, DEFAULT_BEAM_ROLES)


class TestPositionCase:
    @pytest.mark.parametrize(("beams", "case"), [
        ({"omni": ("far_right",)}, "far_right_seen"),
        ({"omni": ("far_left",)}, "far_left_seen"),
        ({"omni": ("front_left", "front_right")}, "front_seen"),
        ({"front_left": ("centre",)}, "front_seen"),
        ({"rear": ("front_left",), "omni": ("front_left",)}, "rear_seen"),
        ({"omni": ("force_field",)}, "front_seen"),
        ({"side_left": ("far_left",)}, None),
        ({}, None),
    ])
    def test_section_2_cases(self, beams: dict[str, tuple[str, ...]], case: str | None
                             ) -> None:
        """Far-R -> left approach, Far-L -> right approach, front L+R -> front, rear -> rear."""
        assert position_case(view(**beams)) == case

    def test_the_oi_buoy_names_count_for_the_front_beams(self) -> None:
        """A code table naming the front beams red_buoy/green_buoy (the OI's) works too."""
        assert front_case(view(omni=("red_buoy", "green_buoy"))) == "front_both"
        assert front_case(view(omni=("red_buoy",))) == "front_left_only"


class TestFrontCase:
    @pytest.mark.parametrize(("beams", "case", "skew"), [
        (("front_left",), "front_left_only", "skew_left"),
        (("front_right",), "front_right_only", "skew_right"),
        (("front_left", "front_right"), "front_both", "centered"),
        (("centre",), "front_both", "centered"),
        (("far_left",), None, "skew_left"),
        ((), None, None),
    ])
    def test_phase_2_and_the_front_case(self, beams: tuple[str, ...], case: str | None,
                                        skew: str | None) -> None:
        assert front_case(view(omni=beams)) == case
        assert skew_case(view(omni=beams)) == skew


class TestSignalCase:
    @pytest.mark.parametrize(("left", "right", "case"), [
        (600, 300, "left_stronger"), (300, 600, "right_stronger"), (500, 480, "balanced"),
        (0, 0, "balanced"),
    ])
    def test_compare(self, left: int, right: int, case: str) -> None:
        assert signal_case(DockSignal(left, right, 0.0), 0.1) == case

    @given(st.integers(0, 1023), st.integers(0, 1023), st.floats(0, 1))
    def test_swapping_the_receivers_swaps_the_answer(self, left: int, right: int,
                                                     ratio: float) -> None:
        """L and R are treated alike: swapped readings give the mirrored case."""
        mirror = {"left_stronger": "right_stronger", "right_stronger": "left_stronger",
                  "balanced": "balanced"}
        one = signal_case(DockSignal(left, right, 0.0), ratio)
        assert signal_case(DockSignal(right, left, 0.0), ratio) == mirror[one]


def _run(rig: Rig, step: Any) -> None:
    async def main() -> None:
        rig.wheels.start_plant()
        await step(rig.ctx, rig.senses())

    vclock.run(main())


class TestPhaseSteps:
    def test_scan_beams_fires_the_case(self) -> None:
        rig = Rig("docking.position.scan_beams")
        rig.ir.see(omni=("far_left",))
        _run(rig, approach.scan_beams)
        assert rig.machine.names == ["far_left_seen"]

    def test_scan_beams_without_a_beam_is_a_lost_signal(self) -> None:
        rig = Rig("docking.position.scan_beams")
        _run(rig, approach.scan_beams)
        assert rig.machine.names == ["signal_lost"]

    @pytest.mark.parametrize(("seen", "trigger"), [
        (("front_left",), "front_left_only"), (("front_right",), "front_right_only"),
        (("front_left", "front_right"), "front_both")])
    def test_front_beam_detect(self, seen: tuple[str, ...], trigger: str) -> None:
        rig = Rig("docking.approach.front_beam_detect")
        rig.ir.see(omni=seen)
        _run(rig, approach.front_beam_detect)
        assert rig.machine.names == [trigger]

    @pytest.mark.parametrize(("handler", "sign"), [
        ("micro_right", -1.0), ("micro_left", 1.0)])
    def test_a_micro_turn_turns_the_seeds_way(self, handler: str, sign: float) -> None:
        """left_only -> micro_right turns right (heading falls), right_only -> micro_left."""
        rig = Rig(f"docking.approach.{handler}")
        rig.ir.see(omni=("front_left",) if sign < 0 else ("front_right",))
        step = approach.APPROACH_LOOP.handlers[f"docking.approach.{handler}"]
        _run(rig, step)
        turned = rig.odometry.pose().theta_rad
        micro = math.radians(rig.settings.get("docking.micro_turn_deg"))
        assert turned == pytest.approx(sign * micro, abs=math.radians(1))
        assert rig.machine.names == ["turned"]

    @pytest.mark.parametrize(("left", "right", "trigger"), [
        (700, 400, "left_stronger"), (400, 700, "right_stronger"), (500, 510, "balanced")])
    def test_signal_compare(self, left: int, right: int, trigger: str) -> None:
        rig = Rig("docking.align.signal_compare")
        rig.signal.value = DockSignal(left, right, 0.0)
        _run(rig, signal_compare)
        assert rig.machine.names == [trigger]

    @pytest.mark.parametrize(("mv", "trigger"), [
        (16_000, "voltage_ok"), (6_500, "voltage_abnormal"), (25_000, "voltage_abnormal"),
        (13_999, "voltage_abnormal")])
    def test_a_contact_voltage_outside_its_limits_is_never_docked(self, mv: int,
                                                                  trigger: str) -> None:
        rig = Rig("docking.dock.voltage_detect")
        rig.contacts.value = DockContacts(mv, 0.0)
        _run(rig, contact.voltage_detect)
        assert rig.machine.names == [trigger]
        if trigger == "voltage_abnormal":
            assert f"{mv} mV outside 14000-19000 mV" in rig.machine.fired[0][1]["reason"]

    def test_direction_turn_leaves_a_robot_facing_away_for_the_rear_case(self) -> None:
        rig = Rig("docking.search.direction_turn")
        rig.ir.see(rear=("front_left",), omni=("front_left",))
        _run(rig, search.direction_turn)
        assert rig.machine.fired == [("direction_found", {"towards": "rear"})]
        assert rig.odometry.pose().theta_rad == 0.0

    def test_force_field_detect_without_the_beam_goes_back_to_the_walls(self) -> None:
        rig = Rig("docking.search.force_field_detect")
        _run(rig, search.force_field_detect)
        assert rig.machine.names == ["field_lost"]
