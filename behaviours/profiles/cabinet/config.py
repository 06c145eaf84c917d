"""The ``cabinet`` config section (the cabinet robot's files and its navigation limits) and
the settings read from it."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from hal.options import Option, Section
from hal.settings import SettingsView

CABINET = Section("cabinet", "The cabinet robot: its map, tasks, node graph and scan fit.", (
    Option("map_file", "str", "cabinet-map.json",
           "The site's JSON map (walls, doors, rooms, cabinets), relative to the config "
           "file's directory."),
    Option("task_file", "str", "cabinet-tasks.json",
           "The task list (cabinets to visit, actions, the task planner's behaviour)."),
    Option("robot_radius_m", "float", 0.20, "The robot's radius (its footprint's circle).",
           min=0.05, max=2.0),
    Option("link_margin_m", "float", 0.10,
           "A link exists where its straight line clears every wall by radius + this.",
           min=0.0, max=2.0),
    Option("door_node_m", "float", 0.50,
           "Door nodes stand this far from the door's middle, one on each side.",
           min=0.1, max=5.0),
    Option("standoff_m", "float", 0.50,
           "The node in front of a cabinet, and the approach's end, this far from its front.",
           min=0.05, max=3.0, tunable=True),
    Option("fit_min_score", "float", 0.50,
           "A scan fit counts only with at least this score (mean beam likelihood, 0-1).",
           min=0.0, max=1.0, tunable=True),
    Option("fit_margin", "float", 0.08,
           "...and only when it beats the best clearly different pose by this much.",
           min=0.0, max=1.0, tunable=True),
    Option("change_orientation_deg", "float", 45.0,
           "Fitting case 2: turn this much before trying again.", min=5.0, max=180.0,
           tunable=True),
    Option("blocked_s", "float", 8.0,
           "Driving to a node: no progress for this long means the link is blocked.",
           min=0.5, max=600.0, tunable=True),
    Option("max_link_resets", "int", 3,
           "Resets of the broken links allowed per task (against a permanent blockade).",
           min=0, max=100, tunable=True),
    Option("fit_fov_deg", "float", 360.0,
           "The scan's usable field of view for the fit, centred ahead (less where the "
           "robot's body or mast hides the rear).", min=30.0, max=360.0),
    Option("fit_min_view_deg", "float", 360.0,
           "A fit counts only once the local map covers this much bearing (the view plus "
           "the turns made): a partial view of a symmetric site fits in several places.",
           min=30.0, max=360.0),
    Option("heading_kp", "float", 1.5, "Drive controller: heading PID, proportional "
           "(rad/s per rad).", min=0.0, max=50.0, tunable=True),
    Option("heading_ki", "float", 0.0, "... integral (rad/s per rad s).", min=0.0, max=50.0,
           tunable=True),
    Option("heading_kd", "float", 0.05, "... derivative (rad/s per rad/s).", min=0.0,
           max=50.0, tunable=True),
    Option("distance_kp", "float", 1.2, "Drive controller: speed per metre still to go, "
           "up to drive.cruise_mps.", min=0.01, max=50.0, tunable=True),
))


def _default(key: str) -> Any:
    return CABINET.by_key[key].default


@dataclass(frozen=True, slots=True)
class CabinetConfig:
    """The ``cabinet`` section (defaults: its defaults)."""

    map_file: str = _default("map_file")
    task_file: str = _default("task_file")
    robot_radius_m: float = _default("robot_radius_m")
    link_margin_m: float = _default("link_margin_m")
    door_node_m: float = _default("door_node_m")
    standoff_m: float = _default("standoff_m")
    fit_min_score: float = _default("fit_min_score")
    fit_margin: float = _default("fit_margin")
    change_orientation_deg: float = _default("change_orientation_deg")
    blocked_s: float = _default("blocked_s")
    max_link_resets: int = _default("max_link_resets")
    fit_fov_deg: float = _default("fit_fov_deg")
    fit_min_view_deg: float = _default("fit_min_view_deg")
    heading_kp: float = _default("heading_kp")
    heading_ki: float = _default("heading_ki")
    heading_kd: float = _default("heading_kd")
    distance_kp: float = _default("distance_kp")

    @property
    def clearance_m(self) -> float:
        """What a link's line must keep from every wall."""
        return self.robot_radius_m + self.link_margin_m

    @property
    def change_orientation_rad(self) -> float:
        return math.radians(self.change_orientation_deg)

    @classmethod
    def from_settings(cls, settings: SettingsView) -> CabinetConfig:
        s = settings.section("cabinet")
        return cls(**{key: s[key] for key in CABINET.by_key})
