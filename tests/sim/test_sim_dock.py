"""A robot with dock IR receivers in the simulator: the rig's real driver, the dock actions."""

from __future__ import annotations

import asyncio
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from sim_dock_rig import DOCK_SCENARIO, dock_rig, reading_after, script_step

from hal.readings import DockIrReading
from sim import vclock
from sim.actions import ACTIONS
from sim.report import draw_trajectory
from sim.rig import SimRig
from sim.scenario import Scenario, ScenarioError, parse_scenario
from sim.world.dock import DEFAULT_BEAMS
from sim.world.geometry import Pose


def _scenario(text: str = DOCK_SCENARIO) -> Scenario:
    return parse_scenario(text, "<test>")


class TestRig:
    def test_a_robot_with_dock_ir_gets_the_real_driver_on_the_simulated_lines(self) -> None:
        """0.86 m out on the dock's axis, facing it: the driver names the front pair and
        the centre beam."""

        async def main() -> DockIrReading:
            rig = await dock_rig(_scenario())
            assert rig.devices.dock_ir is not None
            await rig.devices.dock_ir.start()
            try:
                return await reading_after(rig, 1.0)
            finally:
                await rig.devices.dock_ir.close()
                await rig.close()

        reading = vclock.run(main())
        assert reading.sees("front_left", "front_left")
        assert reading.sees("front_right", "front_right")
        assert reading.sees("omni", "centre")

    def test_a_robot_without_dock_ir_gets_none(self) -> None:
        async def main() -> SimRig:
            rig = await dock_rig(_scenario(), needs=())
            await rig.close()
            return rig

        rig = vclock.run(main())
        assert rig.devices.dock_ir is None and rig.dock_ir is None

    def test_the_world_values_for_the_motor_board(self) -> None:
        async def main() -> dict[str, object]:
            rig = await dock_rig(_scenario())
            values = rig.dock_values()
            await rig.close()
            return values

        values = vclock.run(main())
        assert values["dock_mv"] == 0 and values["bump"] == (False, False)
        irs = values["irs"]
        assert isinstance(irs, tuple) and irs[0] > 0 and irs[0] == irs[1]


class TestActions:
    def test_the_four_dock_actions_are_in_the_table(self) -> None:
        assert {"battery.set", "dock.beams_off", "dock.contacts_fault",
                "dock.move"} <= set(ACTIONS)

    def test_beams_off_for_a_while_then_back(self) -> None:
        async def main() -> tuple[DockIrReading, DockIrReading]:
            scenario = _scenario()
            rig = await dock_rig(scenario)
            assert rig.devices.dock_ir is not None
            await rig.devices.dock_ir.start()
            try:
                ACTIONS["dock.beams_off"](script_step(scenario, rig, duration_s=1.0))
                off = await reading_after(rig, 0.8)
                back = await reading_after(rig, 0.7)
            finally:
                await rig.devices.dock_ir.close()
                await rig.close()
            return off, back

        off, back = vclock.run(main())
        assert all(not beams for beams in off.beams.values())
        assert back.sees("omni", "centre")

    def test_a_contacts_fault_gives_an_abnormal_voltage_then_mends(self) -> None:
        async def main() -> list[int]:
            scenario = _scenario()
            rig = await dock_rig(scenario)
            assert scenario.world.dock is not None
            rig.body.pose = scenario.world.dock.docked_pose(rig.body.params.radius_m)
            volts = [rig.body.contact_mv()]
            ACTIONS["dock.contacts_fault"](script_step(scenario, rig, duration_s=2.0))
            volts.append(rig.body.contact_mv())
            await asyncio.sleep(2.5)
            volts.append(rig.body.contact_mv())
            await rig.close()
            return volts

        good, bad, mended = vclock.run(main())
        assert 14_000 <= good <= 19_000 and not 14_000 <= bad <= 19_000 and mended == good

    def test_move_puts_the_dock_elsewhere(self) -> None:
        async def main() -> tuple[float, float, float]:
            scenario = _scenario()
            rig = await dock_rig(scenario)
            ACTIONS["dock.move"](script_step(scenario, rig, x_m=5.86, y_m=1.0, heading_deg=180))
            await rig.close()
            dock = scenario.world.dock
            assert dock is not None
            return dock.x_m, dock.y_m, math.degrees(dock.heading_rad)

        assert vclock.run(main()) == pytest.approx((5.86, 1.0, 180.0))

    def test_battery_set_sets_the_charge(self) -> None:
        async def main() -> float:
            scenario = _scenario()
            rig = await dock_rig(scenario)
            ACTIONS["battery.set"](script_step(scenario, rig, pct=18))
            await rig.close()
            return rig.body.charge_pct

        assert vclock.run(main()) == 18.0

    @pytest.mark.parametrize(("action", "args", "message"), [
        ("battery.set", {"pct": 120}, r"battery.set.pct: expected 0-100"),
        ("battery.set", {}, r"battery.set.pct: expected a number"),
        ("dock.move", {"x_m": 1.0}, r"dock.move.y_m: expected a number"),
    ])
    def test_bad_arguments_name_the_key(self, action: str, args: dict[str, Any],
                                        message: str) -> None:
        async def main() -> None:
            scenario = _scenario()
            rig = await dock_rig(scenario)
            try:
                ACTIONS[action](script_step(scenario, rig, **args))
            finally:
                await rig.close()

        with pytest.raises(ScenarioError, match=message):
            vclock.run(main())

    def test_dock_actions_in_a_world_without_a_dock_say_so(self) -> None:
        text = DOCK_SCENARIO.replace('dock = { x_m = 0.14, y_m = 2.0, heading_deg = 0 }\n', "")

        async def main() -> None:
            scenario = _scenario(text)
            rig = await dock_rig(scenario)
            try:
                ACTIONS["dock.beams_off"](script_step(scenario, rig))
            finally:
                await rig.close()

        with pytest.raises(ScenarioError, match=r"dock.beams_off: the world has no dock"):
            vclock.run(main())


class TestReport:
    def test_trajectory_png_draws_the_dock_and_its_beams(
            self, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
        """A world with a dock: the plot has one patch per beam and the dock's body."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        shown: list[str] = []
        real_close = plt.close

        def keep_labels(fig: Any = None) -> None:
            shown.extend(str(p.get_label()) for p in fig.axes[0].patches)
            real_close(fig)

        monkeypatch.setattr(plt, "close", keep_labels)
        draw_trajectory(tmp_path / "t.png", _scenario().world, {}, [], "dock")
        assert (tmp_path / "t.png").stat().st_size > 10_000
        assert "dock" in shown
        assert {f"beam {b.name} ({b.code})" for b in DEFAULT_BEAMS} <= set(shown)


class _Board:
    """The docking inputs of a motor board (sim.devices.motor_board.dock_inputs)."""

    def __init__(self) -> None:
        self.dock_signal: Any = None
        self.contact_mv: Any = None
        self.bumpers: Any = None
        self.wall_cm: Any = None
        self.bin_pct: Any = None
        self.evac_listeners: list[Callable[[bool], None]] = []

    def read(self) -> list[object]:
        return [src() for src in (self.dock_signal, self.contact_mv, self.bumpers,
                                  self.wall_cm, self.bin_pct)]


class TestMotorBoardWiring:
    def test_the_board_reads_the_world_and_evac_runs_the_station(self) -> None:
        """10 cm out: IRS on both sides; docked: the station's voltage, no bump (the front
        receivers, beside the emitters now, see nothing); EVAC:1 turns the suction on and
        the open bin empties."""

        async def main() -> tuple[list[object], bool, float]:
            scenario = _scenario()
            rig = await dock_rig(scenario)
            dock = scenario.world.dock
            assert dock is not None
            docked = dock.docked_pose(rig.body.params.radius_m)
            board = _Board()
            rig.wire_dock_inputs(board)
            rig.body.pose = Pose(docked.x_m + 0.1, docked.y_m, docked.heading_rad)
            near = board.read()
            rig.body.pose = docked
            rig.body.bin_pct = 50.0
            values = [near[0], *board.read()[1:]]
            rig.body.servo(90)
            for listener in board.evac_listeners:
                listener(True)
            await asyncio.sleep(2.0)
            bin_pct = rig.body.bin_pct
            await rig.close()
            return values, dock.suction, bin_pct

        (irs, mv, bump, wall, bin_pct), suction, emptied = vclock.run(main())
        assert isinstance(irs, tuple) and min(irs) > 0
        assert mv == 16_000 and bump == (False, False)
        assert isinstance(wall, float) and bin_pct == 50.0
        assert suction and emptied < 50.0
