"""The cabinet robot's init phase, perceptor and path planner blocks: read the JSON map and the
task list, rasterise the map to the nav grid, build the node graph; every problem reported
as ``FILE: where: message`` (``check-config`` and the daemon's start use ``site_problems``)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from behaviours.nav.distance_field import DistanceField
from behaviours.nav.grid import Grid
from behaviours.profiles.cabinet.config import CabinetConfig
from behaviours.profiles.cabinet.map_reader import SiteFileError, parse_site_map, read_json
from behaviours.profiles.cabinet.node_graph import NodeGraph, build_graph
from behaviours.profiles.cabinet.site_map import SiteMap
from behaviours.profiles.cabinet.task_list import TaskList, parse_task_list

__all__ = ["Site", "SiteFileError", "load_site", "site_problems"]


@dataclass(frozen=True, slots=True)
class Site:
    """Everything the init phase builds from the files."""

    site_map: SiteMap
    grid: Grid
    field: DistanceField
    graph: NodeGraph
    tasks: TaskList


def resolve(file: str, base_dir: str | Path | None) -> Path:
    path = Path(file).expanduser()
    if not path.is_absolute() and base_dir is not None:
        path = Path(base_dir) / path
    return path


def build_site(site_map: SiteMap, tasks: TaskList, config: CabinetConfig, shown: str) -> Site:
    """Grid, field and graph of a parsed map; a disconnected graph is a SiteFileError."""
    grid = site_map.grid()
    field = DistanceField(grid)
    graph, problems = build_graph(site_map, field, clearance_m=config.clearance_m,
                                  standoff_m=config.standoff_m,
                                  door_node_m=config.door_node_m,
                                  max_resets=config.max_link_resets)
    if problems:
        raise SiteFileError([f"{shown}: {p}" for p in problems])
    return Site(site_map, grid, field, graph, tasks)


def load_site(config: CabinetConfig, base_dir: str | Path | None = None) -> Site:
    """Read both files and build the site, or SiteFileError with every problem found."""
    map_path = resolve(config.map_file, base_dir)
    site_map = parse_site_map(read_json(map_path, config.map_file), config.map_file,
                              map_path.parent)
    task_path = resolve(config.task_file, base_dir)
    tasks = parse_task_list(read_json(task_path, config.task_file), config.task_file, site_map)
    return build_site(site_map, tasks, config, config.map_file)


def site_problems(config: CabinetConfig, base_dir: str | Path | None = None) -> list[str]:
    """Every problem of the map and task files (empty: the robot can start with them)."""
    try:
        load_site(config, base_dir)
    except SiteFileError as exc:
        return exc.problems
    return []
