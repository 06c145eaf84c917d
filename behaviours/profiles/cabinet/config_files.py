"""The cabinet robot's map and task files, checked with the config that names them: a config
whose ``[cabinet]`` section names its files, or whose robot is the cabinet robot (the default
files then), must name files the robot can start with (``check-config`` prints
``robotd.toml:LINE: cabinet.map_file: map.json: cabinets[2].front: message``). Other robots'
configs (the shipped example with its empty ``[cabinet]`` header) read no files.

A node graph that cannot link only because ``robot_radius_m`` (or ``link_margin_m``) is set
larger than its default (the graph links with the default) is one problem on that key's line,
not one per node on the map's."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

from behaviours.profiles.cabinet.config import CABINET, CabinetConfig
from behaviours.profiles.cabinet.map_reader import parse_site_map, read_json
from behaviours.profiles.cabinet.site import SiteFileError, build_site, resolve
from behaviours.profiles.cabinet.site_map import SiteMap
from behaviours.profiles.cabinet.task_list import TaskList, parse_task_list
from hal.options import ConfigProblem

Where = dict[tuple[str, str], int]
_CLEARANCE_KEYS = ("robot_radius_m", "link_margin_m")


def cabinet_file_problems(values: dict[str, dict[str, Any]], path: str,
                          where: Where) -> list[ConfigProblem]:
    """Problems of the files the cabinet robot will read; none for other robots' configs
    that name none."""
    named = ("cabinet", "map_file") in where or ("cabinet", "task_file") in where
    if not named and values.get("robot", {}).get("profile") != "cabinet":
        return []
    section = values.get("cabinet", {})
    config = CabinetConfig(**{k: section[k] for k in CABINET.by_key if k in section})
    base_dir = Path(path).parent
    try:
        map_path = resolve(config.map_file, base_dir)
        site_map = parse_site_map(read_json(map_path, config.map_file), config.map_file,
                                  map_path.parent)
        tasks = parse_task_list(read_json(resolve(config.task_file, base_dir), config.task_file),
                                config.task_file, site_map)
    except SiteFileError as exc:
        return [_file_problem(p, config, path, where) for p in exc.problems]
    try:
        build_site(site_map, tasks, config, config.map_file)
    except SiteFileError as exc:
        blamed = _clearance_problem(config, site_map, tasks, exc.problems, path, where)
        if blamed is not None:
            return [blamed]
        return [_file_problem(p, config, path, where) for p in exc.problems]
    return []


def _file_problem(problem: str, config: CabinetConfig, path: str, where: Where
                  ) -> ConfigProblem:
    on_tasks = problem.startswith(config.task_file + ":") and config.task_file != config.map_file
    key = "task_file" if on_tasks else "map_file"
    line = where.get(("cabinet", key), where.get(("cabinet", ""), where.get(("robot",
                                                                             "profile"))))
    if ("cabinet", key) not in where:
        problem += f" (the default cabinet.{key}, read by robot.profile cabinet)"
    return ConfigProblem(path, line, f"cabinet.{key}", problem)


def _clearance_problem(config: CabinetConfig, site_map: SiteMap, tasks: TaskList,
                       problems: list[str], path: str, where: Where) -> ConfigProblem | None:
    """One problem on the clearance key when the graph links with the default clearance."""
    changed = [k for k in _CLEARANCE_KEYS if ("cabinet", k) in where
               and getattr(config, k) > CABINET.by_key[k].default]
    if not changed:
        return None
    defaults = {k: CABINET.by_key[k].default for k in _CLEARANCE_KEYS}
    try:
        build_site(site_map, tasks, replace(config, **defaults), config.map_file)
    except SiteFileError:
        return None  # the map is at fault with the default clearance too
    key = max(changed, key=lambda k: getattr(config, k) - CABINET.by_key[k].default)
    near = sum("from a wall" in p for p in problems)
    apart = sum("not connected" in p for p in problems)
    message = (f"the node graph cannot link with robot_radius_m {config.robot_radius_m:g} + "
               f"link_margin_m {config.link_margin_m:g} = {config.clearance_m:.2f} m from every "
               f"wall: {config.map_file} has {near} node(s) nearer a wall and {apart} not "
               f"connected (first: {problems[0]}); it links with the defaults "
               f"{defaults['robot_radius_m']:g} + {defaults['link_margin_m']:g}")
    return ConfigProblem(path, where[("cabinet", key)], f"cabinet.{key}", message)
