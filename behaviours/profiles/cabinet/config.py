"""The ``cabinet`` config section (the cabinet robot's files and its navigation limits),
declared by the ``CabinetConfig`` read from it."""

from __future__ import annotations

import math
from dataclasses import dataclass

from hal.options import load, section_of, setting
from hal.settings import SettingsView


@dataclass(frozen=True, slots=True)
class CabinetConfig:
    """The ``cabinet`` section."""

    map_file: str = setting(
        "cabinet-map.json", "The site's JSON map (walls, doors, rooms, cabinets), relative to "
        "the config file's directory.")
    task_file: str = setting(
        "cabinet-tasks.json",
        "The task list (cabinets to visit, actions, the task planner's behaviour).")
    robot_radius_m: float = setting(0.20, "The robot's radius (its footprint's circle).",
                                    min=0.05, max=2.0)
    link_margin_m: float = setting(
        0.10, "A link exists where its straight line clears every wall by radius + this.",
        min=0.0, max=2.0)
    door_node_m: float = setting(
        0.50, "Door nodes stand this far from the door's middle, one on each side.",
        min=0.1, max=5.0)
    standoff_m: float = setting(
        0.50, "The node in front of a cabinet, and the approach's end, this far from its front.",
        min=0.05, max=3.0, tunable=True)
    fit_min_score: float = setting(
        0.50, "A scan fit counts only with at least this score (mean beam likelihood, 0-1).",
        min=0.0, max=1.0, tunable=True)
    fit_margin: float = setting(
        0.08, "...and only when it beats the best clearly different pose by this much.",
        min=0.0, max=1.0, tunable=True)
    change_orientation_deg: float = setting(
        45.0, "Fitting case 2: turn this much before trying again.", min=5.0, max=180.0,
        tunable=True)
    blocked_s: float = setting(
        8.0, "Driving to a node: no progress for this long means the link is blocked.",
        min=0.5, max=600.0, tunable=True)
    max_link_resets: int = setting(
        3, "Resets of the broken links allowed per task (against a permanent blockade).",
        min=0, max=100, tunable=True)
    fit_fov_deg: float = setting(
        360.0, "The scan's usable field of view for the fit, centred ahead (less where the "
        "robot's body or mast hides the rear).", min=30.0, max=360.0)
    fit_min_view_deg: float = setting(
        360.0, "A fit counts only once the local map covers this much bearing (the view plus "
        "the turns made): a partial view of a symmetric site fits in several places.",
        min=30.0, max=360.0)
    heading_kp: float = setting(
        1.5, "Drive controller: heading PID, proportional (rad/s per rad).", min=0.0,
        max=50.0, tunable=True)
    heading_ki: float = setting(0.0, "... integral (rad/s per rad s).", min=0.0, max=50.0,
                                tunable=True)
    heading_kd: float = setting(0.05, "... derivative (rad/s per rad/s).", min=0.0, max=50.0,
                                tunable=True)
    distance_kp: float = setting(
        1.2, "Drive controller: speed per metre still to go, up to drive.cruise_mps.",
        min=0.01, max=50.0, tunable=True)

    @property
    def clearance_m(self) -> float:
        """What a link's line must keep from every wall."""
        return self.robot_radius_m + self.link_margin_m

    @property
    def change_orientation_rad(self) -> float:
        return math.radians(self.change_orientation_deg)

    @classmethod
    def from_settings(cls, settings: SettingsView) -> CabinetConfig:
        return load(cls, settings.section(CABINET.name))


CABINET = section_of(CabinetConfig, "cabinet",
                     "The cabinet robot: its map, tasks, node graph and scan fit.")
