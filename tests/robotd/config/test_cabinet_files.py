"""check-config reads the cabinet robot's map and task files a ``[cabinet]`` section names."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from robotd.config import ConfigError
from robotd.config.loader import load_config

EXAMPLES = Path(__file__).parents[3] / "behaviours" / "profiles" / "cabinet" / "examples"
CONFIG = '[robot]\nname = "cab"\n\n[cabinet]\nmap_file = "map.json"\ntask_file = "tasks.json"\n'


def setup(tmp_path: Path) -> Path:
    shutil.copy(EXAMPLES / "site.json", tmp_path / "map.json")
    shutil.copy(EXAMPLES / "tasks.json", tmp_path / "tasks.json")
    path = tmp_path / "robotd.toml"
    path.write_text(CONFIG)
    return path


class TestCabinetFiles:
    def test_good_files_pass(self, tmp_path: Path) -> None:
        """The example map and task list are a valid configuration."""
        load_config(setup(tmp_path))

    def test_a_map_error_names_config_line_file_and_json_path(self, tmp_path: Path) -> None:
        """``robotd.toml:5: cabinet.map_file: map.json: cabinets[2].front: ...``."""
        path = setup(tmp_path)
        doc = json.loads((tmp_path / "map.json").read_text())
        doc["cabinets"][2]["front"] = "up"
        (tmp_path / "map.json").write_text(json.dumps(doc))
        with pytest.raises(ConfigError) as info:
            load_config(path)
        assert str(info.value).startswith(
            f"{path}:5: cabinet.map_file: map.json: cabinets[2].front: expected one of")

    def test_a_task_error_is_put_on_the_task_file(self, tmp_path: Path) -> None:
        """A task naming an unknown cabinet is reported against ``cabinet.task_file``."""
        path = setup(tmp_path)
        doc = json.loads((tmp_path / "tasks.json").read_text())
        doc["tasks"][0]["cabinet"] = "c9"
        (tmp_path / "tasks.json").write_text(json.dumps(doc))
        with pytest.raises(ConfigError) as info:
            load_config(path)
        assert (f"{path}:6: cabinet.task_file: tasks.json: tasks[0].cabinet: unknown cabinet "
                "'c9'") in str(info.value)

    def test_no_cabinet_files_named_reads_no_files(self, tmp_path: Path) -> None:
        """Other robots' configs, and a [cabinet] section naming no files, read none."""
        path = tmp_path / "robotd.toml"
        path.write_text('[robot]\nname = "x"\n')
        load_config(path)
        path.write_text('[robot]\nname = "x"\n\n[cabinet]\nstandoff_m = 0.4\n')
        load_config(path)
