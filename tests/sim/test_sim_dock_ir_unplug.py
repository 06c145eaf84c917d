"""The dock IR receivers unplugged in the simulator (``dock_ir.unplug``/``dock_ir.replug``): the
lines go idle at the lowest layer, the real driver shows them quiet, and a docking vacuum takes
it for a lost signal, searches again and docks once they are back."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from sim_dock_rig import DOCK_SCENARIO, dock_rig, reading_after, script_step

from hal.readings import DockIrReading
from robotd.cli import main as cli_main
from sim import vclock
from sim.actions import ACTIONS
from sim.scenario import ScenarioError, parse_scenario

SCENARIOS = Path(__file__).resolve().parents[2] / "sim" / "robots" / "vacuum" / "scenarios"

Observed = tuple[DockIrReading, dict[str, Any], tuple[int, int], DockIrReading]


def _unplugged_then_back(**args: Any) -> Observed:
    """A reading and the driver's status while unplugged, the IRS pair then, and a reading
    after the receivers are back."""

    async def main() -> Observed:
        scenario = parse_scenario(DOCK_SCENARIO, "<test>")
        rig = await dock_rig(scenario)
        device = rig.devices.dock_ir
        assert device is not None
        await device.start()
        try:
            await reading_after(rig, 0.5)
            ACTIONS["dock_ir.unplug"](script_step(scenario, rig, duration_s=2.0, **args))
            off = await reading_after(rig, 1.5)
            status, irs = device.status(), rig.dock_values()["irs"]
            back = await reading_after(rig, 1.0)
        finally:
            await device.close()
            await rig.close()
        assert isinstance(irs, tuple)
        return off, status, irs, back

    return vclock.run(main())


class TestUnplug:
    def test_all_receivers_unplugged_see_nothing_and_are_quiet_then_come_back(self) -> None:
        """No edges at all: no codes, every line quiet for over a second, no strength; back
        after ``duration_s``, no line error counted (the driver cannot tell it from dark)."""
        off, status, irs, back = _unplugged_then_back()
        assert all(not codes for codes in off.codes.values())
        quiet = status["quiet_s"]
        assert all(quiet[r] > 1.0 for r in ("omni", "front_left", "front_right"))
        assert all(q is None or q > 1.0 for q in quiet.values())  # the rest never saw light
        assert status["line_errors"] == 0 and status["running"] is True
        assert irs == (0, 0)
        assert back.sees("omni", "centre") and back.sees("front_left", "front_left")

    def test_one_receiver_unplugged_goes_quiet_alone(self) -> None:
        off, status, irs, _ = _unplugged_then_back(receiver="front_left")
        assert not off.codes["front_left"] and off.sees("front_right", "front_right")
        assert status["quiet_s"]["front_left"] > 1.0 > status["quiet_s"]["front_right"]
        assert irs[0] == 0 < irs[1]

    @pytest.mark.parametrize("receiver", ["nose", ["omni", 3], []])
    def test_a_receiver_that_is_not_fitted_is_a_scenario_error(self, receiver: Any) -> None:
        async def main() -> None:
            scenario = parse_scenario(DOCK_SCENARIO, "<test>")
            rig = await dock_rig(scenario)
            try:
                ACTIONS["dock_ir.unplug"](script_step(scenario, rig, receiver=receiver))
            finally:
                await rig.close()

        with pytest.raises(ScenarioError, match=r"dock_ir\.unplug\.receiver"):
            vclock.run(main())


def _events(report: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in (report / "events.jsonl").read_text().splitlines()]


class TestDockingWithoutReceivers:
    def test_unplugged_while_aligning_is_a_lost_signal_and_docking_resumes(
            self, tmp_path: Path) -> None:
        """docking-left with the receivers' cable out for 12 s from 36 s (the alignment):
        a 904 whose reason says no receiver gave an edge, the search again, no ``recovery``
        (the device still runs), and charging once they are back."""
        text = (SCENARIOS / "docking-left.toml").read_text()
        head, _, _ = text.partition("[success]")
        path = tmp_path / "unplugged.toml"
        path.write_text(head.replace('name = "docking-left"', 'name = "unplugged"') + """
[[script]]
at_s = 36.0
action = "dock_ir.unplug"
duration_s = 12

[success]
time_limit_s = 600
final_state = "docking.charging"
no_collisions = false
""")
        code = cli_main(["sim", str(path), "--quiet", "--report", str(tmp_path / "out")])
        events = _events(tmp_path / "out")
        assert code == 0
        lost = next(e for e in events if e["kind"] == "dock.result")
        assert lost["error_code"] == 904 and lost["error"] == "signal_lost"
        assert "no edge from any receiver" in lost["reason"]
        assert 36.0 < lost["t"] < 48.0
        states = [e["dst"] for e in events if e["kind"] == "transition"]
        assert "recovery" not in states
        i = next(i for i, e in enumerate(events) if e is lost)
        after = next(e for e in events[i:] if e["kind"] == "transition")
        assert after["dst"].startswith("docking.search")
        docked = next(e for e in events if e["kind"] == "dock.result" and e["success"])
        assert docked["t"] > 48.0
