"""The ``map`` and ``planner`` config sections, and the planner's settings read from them."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from hal.options import Option, Section
from hal.settings import SettingsView

MAP = Section("map", "The map the robot navigates (a ROS map_server map, or the walls).", (
    Option("file", "str", "walls",
           "map_server YAML (image, resolution, origin, thresholds, negate, mode), relative "
           "to the config file's directory; 'walls': rasterise the simulated world's walls."),
    Option("resolution_m", "float", 0.05, "Cell size when rasterising walls.",
           min=0.005, max=1.0),
    Option("occupied_min", "int", 65,
           "Cells of at least this value (0-100) are obstacles (trinary maps: 100 only).",
           min=1, max=100),
    Option("unknown_is_occupied", "bool", True,
           "Unknown cells (map_saver's grey) are obstacles: the robot plans only where it "
           "has seen the floor."),
))

PLANNER = Section("planner", "A* planning on the map with clearance and inflation.", (
    Option("clearance_m", "float", 0.30,
           "No path passes closer than this to an obstacle (seed property 10: 30 cm).",
           min=0.0, max=5.0, tunable=True),
    Option("inflation_m", "float", 0.30,
           "Beyond the clearance, cells this much farther cost more: paths keep off walls.",
           min=0.0, max=5.0, tunable=True),
    Option("inflation_weight", "float", 4.0,
           "Extra cost at the clearance's edge, falling linearly to 0 over inflation_m.",
           min=0.0, max=100.0, tunable=True),
    Option("smoothing", "bool", True,
           "Shorten the path by line of sight (keeping the clearance).", tunable=True),
    Option("replan_period_s", "float", 1.0,
           "New obstacles seen in the scan are checked against the path this often.",
           min=0.05, max=60.0, tunable=True),
    Option("no_progress_s", "float", 10.0,
           "No progress towards the goal for this long: the caller is told.",
           min=0.5, max=600.0, tunable=True),
    Option("progress_m", "float", 0.05,
           "Getting this much closer to the goal (along the path) counts as progress.",
           min=0.001, max=5.0, tunable=True),
    Option("goal_tolerance_m", "float", 0.10,
           "The goal is reached this close (seed POSITION_TOLERANCE, property 9).",
           min=0.005, max=2.0, tunable=True),
    Option("obstacle_keep_s", "float", 5.0,
           "Obstacles seen in the scan and not in the map are kept this long.",
           min=0.0, max=3600.0, tunable=True),
))

NAV_SECTIONS = (MAP, PLANNER)


def _default(section: Section, key: str) -> Any:
    return section.by_key[key].default


@dataclass(frozen=True, slots=True)
class PlannerConfig:
    """The ``planner`` section (defaults: its defaults)."""

    clearance_m: float = _default(PLANNER, "clearance_m")
    inflation_m: float = _default(PLANNER, "inflation_m")
    inflation_weight: float = _default(PLANNER, "inflation_weight")
    smoothing: bool = _default(PLANNER, "smoothing")
    replan_period_s: float = _default(PLANNER, "replan_period_s")
    no_progress_s: float = _default(PLANNER, "no_progress_s")
    progress_m: float = _default(PLANNER, "progress_m")
    goal_tolerance_m: float = _default(PLANNER, "goal_tolerance_m")
    obstacle_keep_s: float = _default(PLANNER, "obstacle_keep_s")

    @classmethod
    def from_settings(cls, settings: SettingsView) -> PlannerConfig:
        s = settings.section("planner")
        return cls(**{key: s[key] for key in PLANNER.by_key})


@dataclass(frozen=True, slots=True)
class MapConfig:
    """The ``map`` section."""

    file: str = _default(MAP, "file")
    resolution_m: float = _default(MAP, "resolution_m")
    occupied_min: int = _default(MAP, "occupied_min")
    unknown_is_occupied: bool = _default(MAP, "unknown_is_occupied")

    @classmethod
    def from_settings(cls, settings: SettingsView) -> MapConfig:
        s = settings.section("map")
        return cls(**{key: s[key] for key in MAP.by_key})
