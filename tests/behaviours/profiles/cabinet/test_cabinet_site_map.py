"""The cabinet robot's JSON map and task list: every error named by file and JSON path."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pytest
from cabinet_site_fixture import EXAMPLES, site_doc, tasks_doc

from behaviours.profiles.cabinet.config import CabinetConfig
from behaviours.profiles.cabinet.map_reader import SiteFileError, parse_site_map, read_json
from behaviours.profiles.cabinet.site import load_site, site_problems
from behaviours.profiles.cabinet.task_list import parse_task_list


def problems_of(doc: Any) -> list[str]:
    with pytest.raises(SiteFileError) as info:
        parse_site_map(doc, "map.json")
    return info.value.problems


class TestSiteMap:
    def test_reads_the_example(self) -> None:
        """The example map has its walls, doors, rooms and cabinets, fronts as headings."""
        site = parse_site_map(site_doc(), "map.json")
        assert [d.name for d in site.doors] == ["ab", "a-hall", "b-hall"]
        assert site.cabinet("c1").front_rad == 0.0
        assert site.cabinet("c4").front_rad == pytest.approx(-math.pi / 2)
        assert site.room_at(7.0, 1.0) is not None

    def test_doors_are_open_in_the_grid(self) -> None:
        """Rasterising cuts the doors out of their walls: the door's middle is free."""
        site = parse_site_map(site_doc(), "map.json")
        grid = site.grid()
        assert not grid.occupied[grid.cell_of(5.0, 2.0)]
        assert grid.occupied[grid.cell_of(5.0, 3.5)]

    def test_zero_shifts_every_point(self) -> None:
        """``zero`` moves the map so that point becomes the robot's origin."""
        doc = site_doc()
        doc["zero"] = [1.0, 2.0]
        site = parse_site_map(doc, "map.json")
        assert site.cabinet("c1").position == pytest.approx((-0.6, -1.0))

    def test_not_json(self, tmp_path: Path) -> None:
        """A file that is not JSON names the file and the line."""
        path = tmp_path / "map.json"
        path.write_text('{"walls": [\n  [0, 0, 1, 1],\n  oops]}')
        with pytest.raises(SiteFileError, match=r"^map.json: line 3: not JSON"):
            read_json(path, "map.json")

    def test_nan_is_refused(self, tmp_path: Path) -> None:
        """NaN (which Python's json reads) is refused by name."""
        path = tmp_path / "map.json"
        path.write_text('{"walls": [[0, 0, NaN, 1]]}')
        with pytest.raises(SiteFileError, match="NaN is not a number"):
            read_json(path, "map.json")

    def test_a_wrong_front_names_its_path(self) -> None:
        """A cabinet's bad front is reported as ``map.json: cabinets[2].front: ...``."""
        doc = site_doc()
        doc["cabinets"][2]["front"] = "up"
        assert problems_of(doc) == [
            "map.json: cabinets[2].front: expected one of east, north, west, south or a "
            "heading in degrees, got 'up'"]

    def test_wrong_types_are_all_reported(self) -> None:
        """Every wrong type is reported, not only the first."""
        doc = site_doc()
        doc["walls"][1] = [0, 0, "x", 1]
        doc["rooms"][0]["rect"] = "big"
        doc["cabinets"][1]["position"] = [1, True]
        found = problems_of(doc)
        assert "map.json: walls[1][2]: expected a number, got a string ('x')" in found
        assert any(p.startswith("map.json: rooms[0].rect: expected a list of 4") for p in found)
        assert any(p.startswith("map.json: cabinets[1].position[1]: expected a number")
                   for p in found)

    def test_a_cabinet_outside_its_room(self) -> None:
        """A cabinet whose position is not inside its room is named."""
        doc = site_doc()
        doc["cabinets"][0]["position"] = [7.0, 1.0]
        assert problems_of(doc) == [
            "map.json: cabinets[0].position: (7, 1) is not inside room 'lab'"]

    def test_a_cabinet_in_an_unknown_room(self) -> None:
        """A room name that no room has lists the known rooms."""
        doc = site_doc()
        doc["cabinets"][3]["room"] = "attic"
        assert problems_of(doc) == [
            "map.json: cabinets[3].room: unknown room 'attic' (known: hall, lab, store)"]

    def test_a_door_off_every_wall(self) -> None:
        """A door must be a stretch of a wall."""
        doc = site_doc()
        doc["doors"][0]["segment"] = [2, 2, 3, 2]
        assert problems_of(doc) == [
            "map.json: doors[0].segment: not along any wall (a door is a stretch of a wall)"]

    def test_unknown_keys_and_duplicates(self) -> None:
        """Unknown keys and duplicate names are errors."""
        doc = site_doc()
        doc["colour"] = "red"
        doc["cabinets"][1]["name"] = "c1"
        found = problems_of(doc)
        assert any(p.startswith("map.json: colour: unknown key") for p in found)
        assert "map.json: cabinets[1].name: duplicate name 'c1'" in found

    def test_not_an_object(self) -> None:
        """A document that is not an object says so."""
        assert problems_of([1, 2]) == ["map.json: file: expected a JSON object, got a list "
                                       "([1, 2])"]


class TestTaskList:
    def test_reads_the_example(self) -> None:
        """Tasks keep their order, actions and standoffs."""
        site = parse_site_map(site_doc(), "map.json")
        tasks = parse_task_list(tasks_doc(), "tasks.json", site)
        assert [t.cabinet for t in tasks.tasks] == ["c2", "c4", "c3", "c1"]
        assert tasks.tasks[2].standoff_m == 0.6
        assert tasks.tasks[3].action == "none"

    def test_an_unknown_cabinet(self) -> None:
        """A task naming an unknown cabinet lists the known ones."""
        site = parse_site_map(site_doc(), "map.json")
        doc = tasks_doc()
        doc["tasks"][1]["cabinet"] = "c9"
        with pytest.raises(SiteFileError) as info:
            parse_task_list(doc, "tasks.json", site)
        assert info.value.problems == [
            "tasks.json: tasks[1].cabinet: unknown cabinet 'c9' (known: c1, c2, c3, c4)"]

    def test_bad_behaviour(self) -> None:
        """The planner's behaviour takes only its known values."""
        site = parse_site_map(site_doc(), "map.json")
        doc = tasks_doc()
        doc["behaviour"]["order"] = "random"
        with pytest.raises(SiteFileError, match=r"tasks.json: behaviour.order: expected one"):
            parse_task_list(doc, "tasks.json", site)


class TestLoad:
    def write(self, tmp_path: Path, site: dict[str, Any]) -> CabinetConfig:
        (tmp_path / "map.json").write_text(json.dumps(site))
        (tmp_path / "tasks.json").write_text(json.dumps(tasks_doc()))
        return CabinetConfig(map_file="map.json", task_file="tasks.json")

    def test_the_example_loads(self) -> None:
        """The example files build a connected graph."""
        config = CabinetConfig(map_file="site.json", task_file="tasks.json")
        site = load_site(config, EXAMPLES)
        assert len(site.graph.components()) == 1

    def test_a_disconnected_graph_is_reported_at_load(self, tmp_path: Path) -> None:
        """A room sealed off by walls (its door closed in the map) is named at load."""
        doc = site_doc()
        doc["doors"] = [d for d in doc["doors"] if d["name"] != "b-hall"]
        doc["doors"][0]["segment"] = [5, 1.5, 5, 1.7]  # too narrow for the robot
        found = site_problems(self.write(tmp_path, doc), tmp_path)
        assert found
        assert all(p.startswith("map.json: ") for p in found)
        assert any("cabinets[1]: node cabinet:c2 is not connected" in p for p in found)

    def test_a_missing_file(self, tmp_path: Path) -> None:
        """A file that is not there is one problem naming it."""
        config = CabinetConfig(map_file="nope.json", task_file="tasks.json")
        found = site_problems(config, tmp_path)
        assert len(found) == 1
        assert found[0].startswith("nope.json: file: cannot read")
