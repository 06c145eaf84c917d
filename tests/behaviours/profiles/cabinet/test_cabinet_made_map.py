"""The cabinet site laid on a map the robot made (issue 30): a site file with ``occupancy``
instead of walls, read, checked and planned on; every problem named by file and JSON path."""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from behaviours.nav.grid import Grid
from behaviours.nav.mapping.map_save import write_map
from behaviours.nav.outline import outline_segments
from behaviours.profiles.cabinet.config import CabinetConfig
from behaviours.profiles.cabinet.map_reader import SiteFileError, parse_site_map, read_json
from behaviours.profiles.cabinet.site import load_site, site_problems
from hal.occupancy_map import FREE, OCCUPIED, UNKNOWN, OccupancyMap

SCENARIOS = Path(__file__).parents[4] / "sim" / "robots" / "cabinet" / "scenarios"
MADE = SCENARIOS / "cabinet" / "made"


def _site(tmp_path: Path) -> Path:
    """The made site (its map and site file) copied into ``tmp_path``."""
    for name in ("site.json", "site.yaml", "site.pgm"):
        shutil.copy(MADE / name, tmp_path / name)
    return tmp_path / "site.json"


def _problems(doc: Any, base_dir: Path) -> list[str]:
    with pytest.raises(SiteFileError) as info:
        parse_site_map(doc, "site.json", base_dir)
    return info.value.problems


def test_the_outline_of_a_box_is_its_four_sides() -> None:
    occupied = np.zeros((20, 30), dtype=np.bool_)
    occupied[5:10, 10:20] = True  # rows are y: a 10 x 5 cell box
    segments = outline_segments(Grid(occupied, 0.1, -1.0, 2.0))
    assert len(segments) == 4
    xs = [v for s in segments for v in (s[0], s[2])]
    ys = [v for s in segments for v in (s[1], s[3])]
    assert (min(xs), max(xs)) == pytest.approx((-1.0 + 1.05, -1.0 + 1.95))
    assert (min(ys), max(ys)) == pytest.approx((2.0 + 0.55, 2.0 + 0.95))


def test_the_made_site_is_read_and_planned_on(tmp_path: Path) -> None:
    """Walls from the map's cells, the grid the map's own (unknown blocked), doors open,
    and a connected node graph: the mission can start on it."""
    path = _site(tmp_path)
    site = parse_site_map(read_json(path, "site.json"), "site.json", path.parent)
    assert site.made is not None and len(site.walls) > 20
    grid = site.grid()
    assert grid.resolution_m == 0.05
    assert not grid.occupied[grid.cell_of(5.0, 2.0)]  # door ab, open
    assert grid.occupied[grid.cell_of(5.0, 3.5)]  # the wall beside it
    assert grid.occupied[grid.cell_of(-0.9, -0.9)]  # never seen: blocked
    config = CabinetConfig(map_file="site.json", task_file=str(SCENARIOS / "cabinet" /
                                                               "tasks.json"))
    assert site_problems(config, tmp_path) == []
    loaded = load_site(config, tmp_path)
    assert {n for n in loaded.graph.nodes if n.startswith("cabinet:")} == {
        "cabinet:c1", "cabinet:c2", "cabinet:c3", "cabinet:c4"}
    assert len(loaded.graph.components()) == 1


def test_a_door_shut_while_mapping_is_opened_in_the_grid(tmp_path: Path) -> None:
    cells = np.full((40, 60), FREE, dtype=np.int8)
    cells[:, 30] = OCCUPIED  # a wall at x = 3.0 m, its door (y 1.5..2.5 m) shut when mapped
    write_map(OccupancyMap(cells, 0.1, 0.0, 0.0), tmp_path / "hall")
    doc = {"occupancy": "hall.yaml",
           "doors": [{"name": "d", "segment": [3.05, 1.5, 3.05, 2.5]}],
           "rooms": [{"name": "west", "rect": [0, 0, 3.0, 4.0]},
                     {"name": "east", "rect": [3.1, 0, 6.0, 4.0]}],
           "cabinets": [{"name": "c1", "room": "west", "position": [1.0, 1.0],
                         "front": "east"}]}
    site = parse_site_map(doc, "site.json", tmp_path)
    grid = site.grid()
    assert not grid.occupied[grid.cell_of(3.05, 2.0)]
    assert grid.occupied[grid.cell_of(3.05, 3.0)]


def test_problems_name_the_file_and_key(tmp_path: Path) -> None:
    path = _site(tmp_path)
    doc = json.loads(path.read_text())
    missing = dict(doc, occupancy="nowhere.yaml")
    [problem] = _problems(missing, tmp_path)
    assert problem.startswith("site.json: occupancy: ") and "nowhere.yaml" in problem
    both = dict(doc, walls=[[0, 0, 1, 0]])
    assert _problems(both, tmp_path) == ["site.json: walls: give walls or occupancy, not both"]
    assert _problems(dict(doc, occupancy=3), tmp_path) == [
        "site.json: occupancy: expected a map_server YAML file name, got 3"]
    floating = json.loads(json.dumps(doc))
    floating["doors"][0]["segment"] = [2.5, 1.5, 2.5, 2.5]  # in the middle of the lab
    [problem] = _problems(floating, tmp_path)
    assert problem.startswith("site.json: doors[0].segment: an end is ")
    assert "from the map's nearest wall cell" in problem


def test_unknown_cells_are_no_walls_of_the_fit() -> None:
    """The scan fit matches what was seen: the edge of the unknown draws no line."""
    cells = np.full((10, 10), UNKNOWN, dtype=np.int8)
    cells[2:8, 2:8] = FREE
    occupancy = OccupancyMap(cells, 0.1, 0.0, 0.0)
    assert outline_segments(Grid(occupancy.occupied(), 0.1)) == []
