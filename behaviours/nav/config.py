"""The ``map`` and ``planner`` config sections, declared by the settings read from them."""

from __future__ import annotations

from dataclasses import dataclass

from hal.options import load, section_of, setting
from hal.settings import SettingsView


@dataclass(frozen=True, slots=True)
class MapConfig:
    """The ``map`` section."""

    file: str = setting(
        "walls", "map_server YAML (image, resolution, origin, thresholds, negate, mode), "
        "relative to the config file's directory; 'walls': rasterise the simulated world's "
        "walls.")
    resolution_m: float = setting(0.05, "Cell size when rasterising walls.",
                                  min=0.005, max=1.0)
    occupied_min: int = setting(
        65, "Cells of at least this value (0-100) are obstacles (trinary maps: 100 only).",
        min=1, max=100)
    unknown_is_occupied: bool = setting(
        True, "Unknown cells (map_saver's grey) are obstacles: the robot plans only where it "
        "has seen the floor.")

    @classmethod
    def from_settings(cls, settings: SettingsView) -> MapConfig:
        return load(cls, settings.section(MAP.name))


@dataclass(frozen=True, slots=True)
class ZoneConfig:
    """Zones drawn over the map (the ``map`` section's mask keys): Nav2's keep-out and speed
    filter masks, read by ``behaviours.nav.zones``."""

    keepout_file: str = setting(
        "", "Keep-out mask (Nav2's keepout filter): a map_server YAML whose occupied cells the "
        "robot never plans through, relative to the map file's directory; '': none.")
    keepout_margin_m: float = setting(
        0.10, "Paths keep the robot's centre at least this far from a keep-out cell.",
        min=0.0, max=5.0)
    speed_file: str = setting(
        "", "Speed mask (Nav2's speed filter): a map_server YAML (mode scale) whose cell "
        "values are speed limits, relative to the map file's directory; '': none.")
    speed_type: str = setting(
        "percent", "What a speed mask's limit is: percent of drive.cruise_mps (Nav2's type "
        "1) or absolute m/s (type 2).", choices=("percent", "absolute"))
    speed_base: float = setting(
        100.0, "Nav2's base: a cell's limit is speed_base + speed_multiplier * value (0: no "
        "limit).", min=-1000.0, max=1000.0)
    speed_multiplier: float = setting(
        -1.0, "Nav2's multiplier (100 and -1: a value v limits to 100 - v percent).",
        min=-1000.0, max=1000.0)
    speed_lookahead_m: float = setting(
        0.4, "The limit is the lowest on the path this far ahead (Nav2's min_lookahead), so "
        "the robot is slow before it enters a zone.", min=0.0, max=10.0)

    @classmethod
    def from_settings(cls, settings: SettingsView) -> ZoneConfig:
        return load(cls, settings.section(MAP.name))


@dataclass(frozen=True, slots=True)
class PlannerConfig:
    """The ``planner`` section."""

    clearance_m: float = setting(
        0.30, "No path passes closer than this to an obstacle (seed property 10: 30 cm).",
        min=0.0, max=5.0, tunable=True)
    inflation_m: float = setting(
        0.30, "Beyond the clearance, cells this much farther cost more: paths keep off walls.",
        min=0.0, max=5.0, tunable=True)
    inflation_weight: float = setting(
        4.0, "Extra cost at the clearance's edge, falling linearly to 0 over inflation_m.",
        min=0.0, max=100.0, tunable=True)
    smoothing: bool = setting(True, "Shorten the path by line of sight (keeping the clearance).",
                              tunable=True)
    replan_period_s: float = setting(
        1.0, "New obstacles seen in the scan are checked against the path this often.",
        min=0.05, max=60.0, tunable=True)
    no_progress_s: float = setting(
        10.0, "No progress towards the goal for this long: the caller is told.",
        min=0.5, max=600.0, tunable=True)
    progress_m: float = setting(
        0.05, "Getting this much closer to the goal (along the path) counts as progress.",
        min=0.001, max=5.0, tunable=True)
    goal_tolerance_m: float = setting(
        0.10, "The goal is reached this close (seed POSITION_TOLERANCE, property 9).",
        min=0.005, max=2.0, tunable=True)
    obstacle_keep_s: float = setting(
        5.0, "Obstacles seen in the scan and not in the map are kept this long.",
        min=0.0, max=3600.0, tunable=True)

    @classmethod
    def from_settings(cls, settings: SettingsView) -> PlannerConfig:
        return load(cls, settings.section(PLANNER.name))


MAP = section_of((MapConfig, ZoneConfig), "map",
                 "The map the robot navigates (a ROS map_server map, or the walls).")
PLANNER = section_of(PlannerConfig, "planner",
                     "A* planning on the map with clearance and inflation.")
NAV_SECTIONS = (MAP, PLANNER)
