"""``robotd sim nav``, ``nav-map``, ``nav-kidnap``: the patrol profile on the simulated LD19."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pytest

from robotd.cli import main
from sim.scenario import load_scenario


def _run(name: str, tmp_path: Path, seed: int = 1,
         quiet: bool = True) -> tuple[int, list[dict[str, Any]]]:
    code = main(["sim", name, *(["--quiet"] if quiet else []), "--seed", str(seed),
                 "--report", str(tmp_path)])
    events = [json.loads(line) for line in
              (tmp_path / "events.jsonl").read_text().splitlines()]
    return code, events


class TestNavScenarios:
    @pytest.mark.parametrize("name", ["nav", "nav-map", "nav-kidnap"])
    def test_each_built_in_passes(self, name: str, tmp_path: Path,
                                  capfd: pytest.CaptureFixture[str]) -> None:
        """Each navigation built-in meets its success conditions, with no collision, and no
        ``lidar.stale`` warning when the run ends (the LiDAR shut down is not stale)."""
        code, events = _run(name, tmp_path, quiet=False)  # warnings are logged then
        result = events[-1]
        assert result["reasons"] == []
        assert code == 0
        assert "lidar.stale" not in capfd.readouterr().err
        assert result["figures"]["sim-1"]["collisions"] == 0
        assert (tmp_path / "trajectory.png").stat().st_size > 0

    def test_nav_replans_round_the_unmapped_box(self, tmp_path: Path) -> None:
        """The box the map lacks is on the straight line to goal 0: the first goal takes a
        replan, and the robot's true path never crosses the box."""
        _code, events = _run("nav", tmp_path)
        first = next(e for e in events if e["kind"] == "nav.goal_reached")
        assert first["replans"] >= 1
        figures = events[-1]["figures"]["sim-1"]
        assert figures["goals_reached"] == 4
        assert figures["goal_error_max_m"] <= 0.10
        assert figures["pose_rate_hz"] >= 10.0

    def test_a_kidnap_is_detected_relocalised_and_the_route_finished(self, tmp_path: Path
                                                                     ) -> None:
        """Teleported 1 m: localisation.diverged within 10 s, a global relocalisation within
        30 s of the kidnap, then both goals reached within 10 cm; no recovery (issue 30)."""
        _code, events = _run("nav-kidnap", tmp_path)
        t0 = next(e["t"] for e in events if e.get("action") == "body.teleport")
        diverged = next(e for e in events if e["kind"] == "localisation.diverged")
        assert 0 < diverged["t"] - t0 <= 10.0
        found = next(e for e in events if e["kind"] == "nav.relocalised")
        assert found["ok"] is True and found["t"] - t0 <= 30.0
        assert math.hypot(found["est_x_m"] - found["x_m"], found["est_y_m"] - found["y_m"]) \
            < 0.10
        assert not [e for e in events if e["kind"] == "nav.failed"]
        assert not [e for e in events if e["kind"] == "transition" and e["dst"] == "recovery"]
        figures = events[-1]["figures"]["sim-1"]
        assert figures["goals_reached"] == 2 and figures["goal_error_max_m"] <= 0.10

    def test_the_robot_map_lacks_the_unmapped_box(self) -> None:
        """``mapped = false`` boxes are walls of the world but not of the robot's map."""
        world = load_scenario("nav").world
        assert world.unmapped_walls == 4
        assert world.mapped_walls().shape[0] == world.walls.shape[0] - 4


class TestLidarLoss:
    def test_a_stalled_lidar_ends_in_recovery_with_the_reason(self, tmp_path: Path) -> None:
        """The LiDAR stalls for good: odometry only for lidar_lost_max_s, then the robot
        stops in recovery, saying lidar_lost."""
        source = (Path(__file__).parents[2] / "sim" / "robots" / "patrol" / "scenarios" /
                  "nav-kidnap.toml").read_text()
        text = source.replace('action = "body.teleport"\ndy_m = -1.0',
                              'action = "lidar.stall"')
        text = text.replace("update_min_a_deg = 5.0", "update_min_a_deg = 5.0\n"
                            "lidar_lost_max_s = 2.0")
        text = text.replace("divergence_within_s = 10.0", "")
        text = text.replace("relocalised_within_s = 30.0", "")
        text = text.replace("goals_reached_within_m = 0.10", "")
        text = text.replace('states_reached = ["mission.drive", "mission.at_goal"]\n'
                            'final_state = "idle"', 'states_reached = ["mission.drive", '
                            '"recovery"]\nfinal_state = "recovery"')
        scenario = tmp_path / "stall.toml"
        scenario.write_text(text)
        code = main(["sim", str(scenario), "--quiet", "--seed", "1", "--report",
                     str(tmp_path)])
        events = [json.loads(line) for line in
                  (tmp_path / "events.jsonl").read_text().splitlines()]
        assert code == 0, events[-1]["reasons"]
        failed = next(e for e in events if e["kind"] == "nav.failed")
        assert failed["reason"] == "lidar_lost"
        stall_t = next(e["t"] for e in events if e.get("action") == "lidar.stall")
        assert 2.0 <= failed["t"] - stall_t <= 4.0
