"""Issue 28: the docking seed's branches that were missing or wrong: the force field is the
force-field code, the rear receiver guards every move backwards, a phase step overtaken by
another trigger stops at once (the station's suction), the emptying time keeps to the seed's
10-30 s, and giving up is a fault."""

from __future__ import annotations

import asyncio
import math
from typing import Any

import pytest
from docking_doubles import Rig

from behaviours.docking import search, station
from behaviours.docking.align import MIN_ADJUST_RAD, _adjust
from behaviours.docking.beams import BeamView
from behaviours.docking.config import DEFAULT_BEAM_ROLES, DOCKING_OPTIONS
from behaviours.docking.machine_part import AttemptCallbacks
from behaviours.docking.reverse import back_up
from behaviours.docking.senses import DockSenses, PhaseLoop
from behaviours.docking.tables import WAIT_EMPTY_MAX_S, DockState
from hal.readings import Bumpers, DockIrReading
from sim import vclock


def _run(rig: Rig, step: Any) -> Any:
    async def main() -> Any:
        rig.wheels.start_plant()
        return await step(rig.ctx, rig.senses())

    return vclock.run(main())


class TestForceField:
    def test_only_the_force_field_code_counts_as_the_force_field(self) -> None:
        """A far or front beam is not the seed's "Force Field"; the code 161 beam is, on any
        receiver."""
        def seen(**beams: tuple[str, ...]) -> bool:
            reading = DockIrReading(beams={r: frozenset(b) for r, b in beams.items()})
            return BeamView(reading, DEFAULT_BEAM_ROLES).field_seen()

        assert not seen(omni=("far_left", "red_buoy", "green_buoy", "centre"))
        assert seen(rear=("force_field",))
        assert seen(front_left=("force_field", "red_buoy"))

    def test_force_field_detect_fires_field_detected_on_the_force_field(self) -> None:
        rig = Rig("docking.search.force_field_detect")
        rig.ir.see(omni=("force_field", "far_right"))
        _run(rig, search.force_field_detect)
        assert rig.machine.names == ["field_detected"]

    def test_a_far_beam_alone_is_not_the_force_field(self) -> None:
        """In a far beam only, with no way in (the front pair never sees the dock), the robot
        goes back to the walls instead of calling it the force field."""
        rig = Rig("docking.search.force_field_detect")
        rig.ir.see(omni=("far_left",))
        _run(rig, search.force_field_detect)
        assert rig.machine.fired == [("field_lost", {"homed": None, "reason": "no force field"})]


class TestReverseGuard:
    def test_a_virtual_wall_behind_stops_the_robot_at_once(self) -> None:
        rig = Rig("docking.undock")
        rig.ir.see(rear=("virtual_wall",))
        backed = _run(rig, lambda c, s: back_up(c, s, 0.4, 0.2, why="undock"))
        assert backed == 0.0
        kind, fields = rig.events[-1]
        assert kind == "dock.reverse_guard"
        assert fields["reason"] == "virtual wall behind" and fields["during"] == "undock"

    def test_a_bumper_pressed_before_backing_off_does_not_stop_it(self) -> None:
        """Backing off a bump is why it backs up: only a bumper that closes on the way stops
        it."""
        rig = Rig("docking.dock.align_check")
        rig.bumpers.value = Bumpers(True, False, 0.0)
        backed = _run(rig, lambda c, s: back_up(c, s, 0.1, 0.2, why="align_check"))
        assert backed == pytest.approx(0.1, abs=0.02)
        assert not any(kind == "dock.reverse_guard" for kind, _ in rig.events)

    def test_a_bumper_closing_on_the_way_stops_it(self) -> None:
        rig = Rig("docking.undock")

        async def press_later(rig: Rig) -> None:
            await asyncio.sleep(0.5)
            rig.bumpers.value = Bumpers(False, True, 0.0)

        async def step(ctx: Any, senses: DockSenses) -> float:
            asyncio.get_running_loop().create_task(press_later(rig))
            return await back_up(ctx, senses, 1.0, 0.2, why="undock")

        backed = _run(rig, step)
        assert 0.0 < backed < 0.2
        assert rig.events[-1][1]["reason"] == "bumper pressed"

    def test_undock_backs_out_under_the_guard_and_turns_round(self) -> None:
        rig = Rig("docking.undock")
        _run(rig, station.undock)
        name, fields = rig.machine.fired[-1]
        assert name == "undocked"
        assert fields["backed_m"] == pytest.approx(0.4, abs=0.02)
        assert abs(rig.odometry.pose().theta_rad) == pytest.approx(math.pi, abs=0.02)


class _Station:
    """The station's suction, recording each switch with the loop time."""

    def __init__(self) -> None:
        self.switched: list[tuple[float, bool]] = []

    async def evacuate(self, on: bool) -> None:
        self.switched.append((asyncio.get_running_loop().time(), on))

    def latest(self) -> None:
        return None


class TestPhaseLoop:
    def test_a_step_overtaken_by_another_trigger_is_cancelled(self) -> None:
        """``wait_empty`` ended by its state's timeout: its handler stops there, and the next
        sub-state's handler (suction off) runs at once, not when the old one would have
        ended."""
        rig = Rig("docking.emptying.wait_empty")
        rig.machine.moves = {"suction_off": "docking.emptying.door_close"}
        suction = _Station()
        ran: list[str] = []

        async def long_wait(ctx: Any, senses: DockSenses) -> None:
            ran.append("wait_empty")
            await asyncio.sleep(25.0)
            ran.append("wait_empty ended")

        async def off(ctx: Any, senses: DockSenses) -> None:
            await suction.evacuate(False)
            await ctx.trigger("suction_off")

        loop = PhaseLoop(DockState.EMPTYING, {DockState.WAIT_EMPTY: long_wait,
                                              DockState.VACUUM_OFF: off})

        async def main() -> None:
            task = asyncio.create_task(loop.run(rig.ctx, rig.senses()))
            await asyncio.sleep(3.0)
            rig.machine.state = DockState.VACUUM_OFF  # wait_empty's timeout fired
            await asyncio.sleep(1.0)
            task.cancel()

        vclock.run(main())
        assert ran == ["wait_empty"]
        assert suction.switched and suction.switched[0][0] < 3.2

    def test_emptying_keeps_to_the_seed_s_10_to_30_s(self) -> None:
        """empty_min_s and empty_max_s cannot go past wait_empty's hard 30 s timeout."""
        options = {o.key: o for o in DOCKING_OPTIONS}
        for key in ("empty_min_s", "empty_max_s"):
            assert options[key].max == WAIT_EMPTY_MAX_S
            _value, problem = options[key].check(300.0)
            assert problem is not None


class TestAlign:
    def test_a_micro_adjust_never_shrinks_below_a_turn_the_robot_can_make(self) -> None:
        rig = Rig("docking.align.micro_adjust_r")
        senses = rig.senses()
        senses.run.adjust_rad = math.radians(1.0)

        async def main() -> None:
            rig.wheels.start_plant()
            for sign in (-1.0, 1.0, -1.0, 1.0, -1.0):
                await _adjust(rig.ctx, senses, sign)

        vclock.run(main())
        assert senses.run.adjust_rad == MIN_ADJUST_RAD


class _Event:
    def __init__(self, name: str, **kwargs: Any) -> None:
        self.event = type("E", (), {"name": name})()
        self.kwargs = kwargs


class TestGivingUp:
    def test_giving_up_is_a_fault_robotctl_shows_in_recovery(self) -> None:
        rig = Rig("recovery")
        callbacks = AttemptCallbacks(rig.ctx)
        callbacks.gave_up_docking(_Event("contact_failed", reason="no contact"))
        fault = rig.ctx.fault
        assert fault is not None and fault.code == "dock_failed"
        assert "no contact" in fault.message
        assert any(kind == "dock.gave_up" for kind, _ in rig.events)

    def test_a_lost_dock_ir_has_its_own_fault_code(self) -> None:
        rig = Rig("recovery")
        AttemptCallbacks(rig.ctx).gave_up_docking(_Event("dock_ir_lost", reason="unplugged"))
        assert rig.ctx.fault is not None and rig.ctx.fault.code == "dock_ir_lost"
