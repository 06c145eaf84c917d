"""The cabinet robot's map and task files, checked with the config that names them: a config
whose ``[cabinet]`` section names its files must name files the robot can start with
(``check-config`` prints ``robotd.toml:LINE: cabinet.map_file: map.json: cabinets[2].front:
message``). A config that names neither (every other robot's, the shipped example with its
empty ``[cabinet]`` header) reads no files."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from behaviours.profiles.cabinet.config import CABINET, CabinetConfig
from behaviours.profiles.cabinet.site import site_problems
from robotd.config.errors import ConfigProblem


def cabinet_file_problems(values: dict[str, dict[str, Any]], path: str,
                          where: dict[tuple[str, str], int]) -> list[ConfigProblem]:
    """Problems of the files a ``[cabinet]`` section names; none when it names none."""
    if ("cabinet", "map_file") not in where and ("cabinet", "task_file") not in where:
        return []
    section = values.get("cabinet", {})
    config = CabinetConfig(**{k: section[k] for k in CABINET.by_key if k in section})
    out = []
    for problem in site_problems(config, Path(path).parent):
        key = "cabinet.task_file" if problem.startswith(config.task_file + ":") and \
            config.task_file != config.map_file else "cabinet.map_file"
        line = where.get(("cabinet", key.split(".")[1]), where.get(("cabinet", "")))
        out.append(ConfigProblem(path, line, key, problem))
    return out
