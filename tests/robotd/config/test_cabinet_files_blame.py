"""check-config checks the files the cabinet profile will read (defaults included), reports a
NaN at its JSON path, and blames a too-large robot radius on its own key."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from behaviours.profiles.cabinet.map_reader import SiteFileError, read_json
from robotd.config import ConfigError
from robotd.config.loader import load_config

EXAMPLES = Path(__file__).parents[3] / "behaviours" / "profiles" / "cabinet" / "examples"
CONFIG = '[robot]\nname = "cab"\n\n[cabinet]\nmap_file = "map.json"\ntask_file = "tasks.json"\n'


def setup(tmp_path: Path, extra: str = "") -> Path:
    shutil.copy(EXAMPLES / "site.json", tmp_path / "map.json")
    shutil.copy(EXAMPLES / "tasks.json", tmp_path / "tasks.json")
    path = tmp_path / "robotd.toml"
    path.write_text(CONFIG + extra)
    return path


def problems(path: Path) -> list[str]:
    with pytest.raises(ConfigError) as info:
        load_config(path)
    return str(info.value).splitlines()


class TestProfileDefaults:
    def test_profile_cabinet_without_section_checks_the_default_map(self, tmp_path: Path
                                                                    ) -> None:
        """No [cabinet] section: the default map file is read, named with its key."""
        path = tmp_path / "robotd.toml"
        path.write_text('[robot]\nname = "cab"\nprofile = "cabinet"\n')
        [line] = problems(path)
        assert line.startswith(f"{path}:3: cabinet.map_file: cabinet-map.json: file: cannot "
                               "read: ")
        assert str(tmp_path / "cabinet-map.json") in line
        assert line.endswith("(the default cabinet.map_file, read by robot.profile cabinet)")

    def test_profile_cabinet_with_the_default_files_present_passes(self, tmp_path: Path
                                                                   ) -> None:
        """The default files beside the config are read and pass."""
        shutil.copy(EXAMPLES / "site.json", tmp_path / "cabinet-map.json")
        shutil.copy(EXAMPLES / "tasks.json", tmp_path / "cabinet-tasks.json")
        path = tmp_path / "robotd.toml"
        path.write_text('[robot]\nname = "cab"\nprofile = "cabinet"\n')
        load_config(path)

    def test_a_missing_default_task_file_is_put_on_task_file(self, tmp_path: Path) -> None:
        """Only the map named: the default task file's problem names ``cabinet.task_file``."""
        shutil.copy(EXAMPLES / "site.json", tmp_path / "map.json")
        path = tmp_path / "robotd.toml"
        path.write_text('[robot]\nname = "cab"\nprofile = "cabinet"\n\n[cabinet]\n'
                        'map_file = "map.json"\n')
        [line] = problems(path)
        assert line.startswith(f"{path}:5: cabinet.task_file: cabinet-tasks.json: file: ")


class TestNaN:
    def test_a_nan_is_reported_at_its_json_path(self, tmp_path: Path) -> None:
        """``map.json: cabinets[1].position[1]: NaN is not a number``, not a line number."""
        path = setup(tmp_path)
        text = json.dumps(json.loads((tmp_path / "map.json").read_text()), indent=1)
        doc = json.loads(text)
        doc["cabinets"][1]["position"][1] = float("nan")
        (tmp_path / "map.json").write_text(json.dumps(doc, indent=1))
        assert problems(path) == [f"{path}:5: cabinet.map_file: map.json: cabinets[1]."
                                  "position[1]: NaN is not a number (JSON has no NaN or "
                                  "Infinity)"]

    def test_every_constant_is_reported_in_document_order(self, tmp_path: Path) -> None:
        """Each NaN/Infinity anywhere (even under keys nobody reads) is named by its path."""
        file = tmp_path / "m.json"
        file.write_text('{"walls": [[0, 0, Infinity, 1]], "x": {"y": -Infinity}, "z": NaN}')
        with pytest.raises(SiteFileError) as info:
            read_json(file, "m.json")
        assert [p.split(": ")[1] for p in info.value.problems] == ["walls[0][2]", "x.y", "z"]
        assert info.value.problems[1].endswith("-Infinity is not a number (JSON has no NaN or "
                                               "Infinity)")


class TestClearanceBlame:
    def test_a_too_large_radius_is_one_problem_on_its_key(self, tmp_path: Path) -> None:
        """robot_radius_m = 1.5: one problem, on robot_radius_m's line, saying why."""
        path = setup(tmp_path, "robot_radius_m = 1.5\n")
        [line] = problems(path)
        assert line.startswith(f"{path}:7: cabinet.robot_radius_m: the node graph cannot link "
                               "with robot_radius_m 1.5 + link_margin_m 0.1 = 1.60 m")
        assert "it links with the defaults 0.2 + 0.1" in line

    def test_a_too_large_margin_is_blamed_on_the_margin(self, tmp_path: Path) -> None:
        """link_margin_m = 1.5 alone is blamed on link_margin_m."""
        path = setup(tmp_path, "link_margin_m = 1.5\n")
        [line] = problems(path)
        assert line.startswith(f"{path}:7: cabinet.link_margin_m: the node graph cannot link")

    def test_a_map_at_fault_with_the_defaults_stays_on_the_map(self, tmp_path: Path) -> None:
        """A map that cannot link even with the default clearance is still the map's fault."""
        path = setup(tmp_path, "robot_radius_m = 0.3\n")
        doc = json.loads((tmp_path / "map.json").read_text())
        c = doc["cabinets"][0]
        doc["walls"].append([c["position"][0] - 5, c["position"][1] + 0.6,
                             c["position"][0] + 5, c["position"][1] + 0.6])
        (tmp_path / "map.json").write_text(json.dumps(doc))
        lines = problems(path)
        assert lines and all(": cabinet.map_file: map.json: " in line for line in lines)
        assert any("not connected to the rest of the graph" in line for line in lines)
