"""``robotd sim turtlebot3-square``: a map_saver map (PGM + YAML) as the simulated world."""

from __future__ import annotations

import json
from pathlib import Path

from robotd.cli import main
from sim.scenario import load_scenario


class TestMapWorldScenario:
    def test_the_map_is_the_world_with_its_origin(self) -> None:
        """The built-in's walls are the map's occupied cells, around negative coordinates."""
        scenario = load_scenario("turtlebot3-square")
        world = scenario.world
        assert world.map_source.endswith("maps/turtlebot3_world.yaml")
        assert world.walls.shape[0] > 100
        assert world.x_min_m < -2.0 and world.y_min_m < -2.0
        assert world.clearance_m(0.0, 0.0) == 0.0 or world.clearance_m(0.0, 0.0) < 0.2

    def test_the_square_round_the_centre_pillar_passes(self, tmp_path: Path) -> None:
        """The square profile drives round the centre pillar, between the others: no contact."""
        code = main(["sim", "turtlebot3-square", "--quiet", "--seed", "3", "--report",
                     str(tmp_path)])
        assert code == 0
        lines = (tmp_path / "events.jsonl").read_text().splitlines()
        result = json.loads(lines[-1])
        assert result["ok"] is True
        assert result["figures"]["sim-1"]["collisions"] == 0
