"""The robot's map as the ``map`` section names it: a map_server YAML, or the world's walls.

A map file that cannot be used is a ``MapFileError`` whose message is ``PATH: what is wrong``;
``check-config`` and the daemon's start read the file through ``map_problem`` so a bad map
keeps the daemon from starting rather than failing when the robot first plans.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from pathlib import Path

from behaviours.nav.config import MapConfig
from behaviours.nav.grid import Grid
from hal.occupancy_map import MapFileError, OccupancyMap, read_map_yaml

WALLS = "walls"

__all__ = ["WALLS", "MapFileError", "load_grid", "map_path", "map_problem"]


def map_path(file: str, base_dir: str | Path | None) -> Path:
    """The map file's path: absolute as given, else relative to ``base_dir`` (the config
    file's directory), ``~`` expanded."""
    path = Path(file).expanduser()
    if not path.is_absolute() and base_dir is not None:
        path = Path(base_dir) / path
    return path


def load_grid(config: MapConfig, *, base_dir: str | Path | None = None,
              walls: Iterable[Sequence[float]] | None = None) -> Grid:
    """The obstacle grid: the map file read, or ``walls`` rasterised when ``file = "walls"``."""
    if config.file == WALLS:
        if walls is None:
            msg = "map.file: 'walls' needs the simulated world's walls (hal.backend = sim)"
            raise MapFileError(msg)
        return Grid.from_segments(walls, config.resolution_m)
    occupancy = read_map_yaml(map_path(config.file, base_dir))
    return grid_of(occupancy, config)


def grid_of(occupancy: OccupancyMap, config: MapConfig) -> Grid:
    return Grid.from_map(occupancy, occupied_min=config.occupied_min,
                         unknown_is_occupied=config.unknown_is_occupied)


def map_problem(file: str, base_dir: str | Path | None) -> str | None:
    """``PATH: what is wrong`` for a map file that cannot be used, or None (also for walls)."""
    if file == WALLS:
        return None
    try:
        read_map_yaml(map_path(file, base_dir))
    except MapFileError as exc:
        return str(exc)
    return None
