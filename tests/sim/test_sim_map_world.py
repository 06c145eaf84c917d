"""``robotd sim depot-square``: a site's map_server map (PGM + YAML) as the simulated world."""

from __future__ import annotations

import json
from pathlib import Path

from robotd.cli import main
from sim.scenario import load_scenario


class TestMapWorldScenario:
    def test_the_map_is_the_world_with_its_origin(self) -> None:
        """The built-in's walls are the depot map's occupied cells' sides; the floor is the
        cells the map knows, plus 0.5 m."""
        scenario = load_scenario("depot-square")
        world = scenario.world
        assert world.map_source.endswith("maps/depot.yaml")
        assert world.walls.shape[0] > 1000
        assert world.x_min_m == -0.5 and world.y_min_m == -0.5
        assert world.clearance_m(7.6, 4.0) < 0.2  # a pillar

    def test_the_square_beside_the_pillar_passes(self, tmp_path: Path) -> None:
        """The square profile drives its square on the depot's floor: no contact."""
        code = main(["sim", "depot-square", "--quiet", "--seed", "3", "--report",
                     str(tmp_path)])
        assert code == 0
        lines = (tmp_path / "events.jsonl").read_text().splitlines()
        result = json.loads(lines[-1])
        assert result["ok"] is True
        assert result["figures"]["sim-1"]["collisions"] == 0
