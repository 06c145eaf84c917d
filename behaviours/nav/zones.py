"""Zones drawn over the map: Nav2's keep-out and speed filter masks, and what they ask of a path.

A mask is a ``map_server`` map (PGM + YAML) over the site, read as the map is
(``hal.occupancy_map``: Nav2's ``map_io`` rules); it need not share the map's grid. As Nav2's
costmap filters read them:

- **keep-out** (``KeepoutFilter``): its occupied cells are lethal. The planner never puts the
  robot's centre in one, and keeps it ``keepout_margin_m`` clear of them (ours: a path hugging a
  zone's edge would cross it by the tracking error);
- **speed** (``SpeedFilter``): a cell's value ``v`` (0..100; draw it in ``mode: scale``) is a
  limit ``speed_base + speed_multiplier * v``, in percent of the robot's top speed (type 1) or
  in m/s (type 2). As in Nav2, 0 and unknown cells mean no limit, and so do limits out of range
  (a percentage outside (0, 100], a speed <= 0: Nav2's controller reads 0 as "no limit"). The
  limit applied is the lowest at the robot and on its path ``speed_lookahead_m`` ahead (Nav2's
  path look-ahead), so the robot has slowed before it enters a slower zone.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
import numpy.typing as npt

from behaviours.nav.config import ZoneConfig
from behaviours.nav.grid import BoolGrid, Grid
from behaviours.nav.map_file import WALLS, map_path
from behaviours.nav.planner import KeepoutCells
from hal.occupancy_map import MapFileError, OccupancyMap, read_map_yaml
from hal.options import ConfigProblem

FloatArray = npt.NDArray[np.float64]
Point = tuple[float, float]


def mask_path(file: str, map_file: str | Path | None) -> Path:
    """A mask's path: absolute as given, else beside the map file (masks are drawn on the map
    and shipped with it), ``~`` expanded."""
    path = Path(file).expanduser()
    if not path.is_absolute() and map_file is not None:
        path = Path(map_file).expanduser().parent / path
    return path


def mask_values(mask: OccupancyMap, x_m: npt.ArrayLike, y_m: npt.ArrayLike
                ) -> npt.NDArray[np.int16]:
    """The mask's cell values at points (-1, unknown, off the mask)."""
    xs = np.asarray(x_m, dtype=np.float64)
    ys = np.asarray(y_m, dtype=np.float64)
    col = np.floor((xs - mask.origin_x_m) / mask.resolution_m).astype(np.intp)
    row = np.floor((ys - mask.origin_y_m) / mask.resolution_m).astype(np.intp)
    inside = (row >= 0) & (row < mask.height) & (col >= 0) & (col < mask.width)
    values = np.full(xs.shape, -1, dtype=np.int16)
    values[inside] = mask.cells[row[inside], col[inside]]
    return values


@dataclass(frozen=True, slots=True)
class SpeedRule:
    """Nav2's ``CostmapFilterInfo`` for a speed mask: ``limit = base + multiplier * value``."""

    percent: bool = True
    base: float = 100.0
    multiplier: float = -1.0

    def limits(self, values: npt.NDArray[np.int16]) -> FloatArray:
        """Each value's limit (percent or m/s); NaN where there is none."""
        v = values.astype(np.float64)
        limit = self.base + self.multiplier * v
        none = (values <= 0) | (limit <= 0)
        if self.percent:
            none |= limit > 100.0
        result: FloatArray = np.where(none, np.nan, limit)
        return result

    def mps(self, limit: float, top_mps: float) -> float:
        """A limit as a speed: a percentage of ``top_mps``, or the m/s themselves."""
        return top_mps * limit / 100.0 if self.percent else limit


@dataclass(frozen=True, slots=True)
class SpeedLimit:
    """The limit in force: ``limit_mps`` (None: none), the mask's value and limit that set it."""

    limit_mps: float | None
    value: int = 0
    limit: float = math.nan


NO_LIMIT = SpeedLimit(None)
SPEED_MARGIN = 0.95
"""The drive aims this far under a zone's limit: its speed is set open-loop (PWM through the
motor board's calibration), and wheel slip and the PWM's steps put the true speed up to 1-2 %
over the commanded one."""


class Zones:
    """The keep-out and speed masks of one site (either may be absent)."""

    def __init__(self, keepout: OccupancyMap | None = None, speed: OccupancyMap | None = None,
                 *, rule: SpeedRule | None = None, keepout_margin_m: float = 0.10,
                 lookahead_m: float = 0.4) -> None:
        self.keepout = keepout
        self.speed = speed
        self.rule = rule or SpeedRule()
        self.keepout_margin_m = keepout_margin_m
        self.lookahead_m = lookahead_m

    @classmethod
    def from_config(cls, config: ZoneConfig, map_file: str | Path | None) -> Zones:
        """The masks the ``map`` section names (MapFileError, ``PATH: what``, if unusable)."""
        keepout = speed = None
        if config.keepout_file:
            keepout = read_map_yaml(mask_path(config.keepout_file, map_file))
        if config.speed_file:
            speed = read_map_yaml(mask_path(config.speed_file, map_file))
        rule = SpeedRule(config.speed_type == "percent", config.speed_base,
                         config.speed_multiplier)
        return cls(keepout, speed, rule=rule, keepout_margin_m=config.keepout_margin_m,
                   lookahead_m=config.speed_lookahead_m)

    @property
    def active(self) -> bool:
        return self.keepout is not None or self.speed is not None

    def describe(self) -> dict[str, object]:
        """The masks and the speed rule (the ``nav.zones`` event: the report draws them)."""
        return {"keepout_file": None if self.keepout is None else self.keepout.source,
                "keepout_margin_m": self.keepout_margin_m,
                "speed_file": None if self.speed is None else self.speed.source,
                "speed_type": "percent" if self.rule.percent else "absolute",
                "speed_base": self.rule.base, "speed_multiplier": self.rule.multiplier,
                "speed_lookahead_m": self.lookahead_m}

    # --- keep-out --------------------------------------------------------------------------

    def keepout_cells(self, grid: Grid) -> BoolGrid:
        """The map grid's cells whose centre lies in a keep-out cell."""
        if self.keepout is None:
            return np.zeros(grid.occupied.shape, dtype=np.bool_)
        xs, ys = _centres(grid)
        blocked: BoolGrid = mask_values(self.keepout, xs, ys) >= _KEEPOUT_MIN
        return blocked

    def keepout_for(self, grid: Grid) -> KeepoutCells | None:
        """The planner's keep-out cells on the map grid: inside a zone, and near one (inside,
        or nearer than ``keepout_margin_m`` plus half a cell's diagonal, as the clearance
        rule: then a straight cut through cells not near one stays clear as well)."""
        if self.keepout is None:
            return None
        inside = self.keepout_cells(grid)
        if not inside.any() or self.keepout_margin_m <= 0:
            return KeepoutCells(inside, inside.copy())
        src = np.where(inside, 0, 255).astype(np.uint8)
        cells = cv2.distanceTransform(src, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
        edge_m = self.keepout_margin_m + grid.resolution_m * math.sqrt(0.5)
        near: BoolGrid = cells * grid.resolution_m < edge_m
        return KeepoutCells(inside, near)

    def in_keepout(self, x_m: float, y_m: float) -> bool:
        """Whether a map point lies in a keep-out cell."""
        if self.keepout is None:
            return False
        return bool(mask_values(self.keepout, x_m, y_m) >= _KEEPOUT_MIN)

    # --- speed -----------------------------------------------------------------------------

    def limit_along(self, points: Sequence[Point], top_mps: float) -> SpeedLimit:
        """The lowest limit at the first point and on the polyline ``lookahead_m`` beyond it
        (sampled every half mask cell)."""
        if self.speed is None or not points:
            return NO_LIMIT
        xy = _ahead(points, self.lookahead_m, self.speed.resolution_m / 2)
        values = mask_values(self.speed, xy[:, 0], xy[:, 1])
        limits = self.rule.limits(values)
        if np.all(np.isnan(limits)):
            return NO_LIMIT
        i = int(np.nanargmin(limits))
        limit = float(limits[i])
        return SpeedLimit(self.rule.mps(limit, top_mps), int(values[i]), limit)

    def limit_at(self, x_m: float, y_m: float, top_mps: float) -> SpeedLimit:
        """The limit at one map point (no look-ahead)."""
        if self.speed is None:
            return NO_LIMIT
        value = mask_values(self.speed, np.array([x_m]), np.array([y_m]))
        limit = float(self.rule.limits(value)[0])
        if math.isnan(limit):
            return NO_LIMIT
        return SpeedLimit(self.rule.mps(limit, top_mps), int(value[0]), limit)


_KEEPOUT_MIN = 100
"""A keep-out mask's lethal cells: occupied (trinary masks give 100, as Nav2's filter reads)."""


def _centres(grid: Grid) -> tuple[FloatArray, FloatArray]:
    cols = grid.origin_x_m + (np.arange(grid.cols) + 0.5) * grid.resolution_m
    rows = grid.origin_y_m + (np.arange(grid.rows) + 0.5) * grid.resolution_m
    xs, ys = np.meshgrid(cols, rows)
    return xs, ys


def _ahead(points: Sequence[Point], distance_m: float, step_m: float) -> FloatArray:
    """Points along the polyline from its first point, every ``step_m``, up to ``distance_m``
    along it (the first point always)."""
    out = [np.asarray(points[0], dtype=np.float64).reshape(1, 2)]
    left = distance_m
    for a, b in itertools.pairwise(points):
        if left <= 0:
            break
        ax, ay = a
        bx, by = b
        length = math.hypot(bx - ax, by - ay)
        if length == 0:
            continue
        run = min(length, left)
        t = np.linspace(0.0, run, max(2, math.ceil(run / step_m) + 1)) / length
        out.append(np.column_stack((ax + t * (bx - ax), ay + t * (by - ay))))
        left -= run
    return np.concatenate(out)


def zone_file_problems(values: dict[str, dict[str, object]], path: str,
                       where: dict[tuple[str, str], int]) -> list[ConfigProblem]:
    """``check-config``'s problems with the masks the ``map`` section names (a mask that does
    not parse keeps the daemon from starting, as a bad map does):
    ``robotd.toml:LINE: map.keepout_file: PATH: what is wrong``."""
    section = values.get("map", {})
    map_file = section.get("file", WALLS)
    map_at = None if map_file == WALLS or not isinstance(map_file, str) \
        else map_path(map_file, Path(path).parent)
    problems = []
    for key in ("keepout_file", "speed_file"):
        name = section.get(key)
        if not isinstance(name, str) or not name:
            continue
        try:
            read_map_yaml(mask_path(name, map_at))
        except MapFileError as exc:
            problems.append(ConfigProblem(path, where.get(("map", key)), f"map.{key}",
                                          str(exc)))
    return problems

