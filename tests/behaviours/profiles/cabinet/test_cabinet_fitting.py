"""The fitting phase's honesty on hand-made scans: a partial view of one straight wall is
refused (it pins the pose in one direction only), a view with corners and the cabinet boxes is
accepted where the robot is, and the usable field of view is applied."""

from __future__ import annotations

import math

import numpy as np
from cabinet_site_fixture import site_doc, tasks_doc

from behaviours.motion.odometry import Odometry
from behaviours.nav.scan_match import MatchConfig, ScanMatcher
from behaviours.profiles.cabinet.config import CabinetConfig
from behaviours.profiles.cabinet.map_reader import parse_site_map
from behaviours.profiles.cabinet.site import build_site
from behaviours.profiles.cabinet.steps.fitting import Fitting, in_view
from behaviours.profiles.cabinet.steps.mission import Mission
from behaviours.profiles.cabinet.task_list import parse_task_list
from sim.world.geometry import raycast


def _fitting() -> Fitting:
    config = CabinetConfig()
    site_map = parse_site_map(site_doc(), "site.json")
    site = build_site(site_map, parse_task_list(tasks_doc(), "tasks.json", site_map), config,
                      "site.json")
    mission = Mission(config, Odometry(0.3, 0.035, 1000))
    mission.site = site
    mission.matcher = ScanMatcher(site.field, site_map.wall_array(), MatchConfig())
    return Fitting(mission)


def _scan(fitting: Fitting, pose: tuple[float, float, float]) -> np.ndarray:
    assert fitting.m.site is not None
    walls = fitting.m.site.site_map.wall_array()
    angles = np.linspace(-math.pi, math.pi, 450, endpoint=False)
    ranges = raycast(walls, pose[0], pose[1], angles + pose[2], 8.0)
    ok = ranges < 8.0
    return np.column_stack((ranges[ok] * np.cos(angles[ok]), ranges[ok] * np.sin(angles[ok])))


def test_a_straight_wall_alone_is_refused_as_degenerate() -> None:
    """Facing the lab's south wall up close with a 40 degree view: no fit, whatever the score."""
    fitting = _fitting()
    pose = (2.0, 1.0, -math.pi / 2)
    points = in_view(_scan(fitting, pose), 40.0)
    assert "degenerate" in fitting._implausible(points, pose)


def test_the_full_view_is_plausible_where_the_robot_is() -> None:
    """A 360 degree scan in the lab fits the map there: nothing implausible about it."""
    fitting = _fitting()
    assert fitting.m.matcher is not None
    pose = (2.2, 2.6, 0.3)
    points = _scan(fitting, pose)
    fit = fitting.m.matcher.fit_global(points, (0.0, 0.0, 10.0, 6.0))
    assert fit.accepted
    assert math.hypot(fit.pose[0] - pose[0], fit.pose[1] - pose[1]) < 0.05
    assert fitting._implausible(points, fit.pose) == ""


def test_a_pose_outside_the_rooms_is_refused() -> None:
    """A pose off the building is never the robot's, however well the points lie on walls."""
    fitting = _fitting()
    pose = (2.0, 1.0, -math.pi / 2)
    points = _scan(fitting, pose)
    assert "no room" in fitting._implausible(points, (12.0, 1.0, 0.0))


def test_in_view_keeps_the_points_ahead() -> None:
    """A 90 degree view keeps bearings within 45 degrees of ahead; 360 keeps everything."""
    pts = np.array([[1.0, 0.0], [1.0, 0.9], [0.0, 1.0], [-1.0, 0.0]])
    assert in_view(pts, 90.0).tolist() == [[1.0, 0.0], [1.0, 0.9]]
    assert in_view(pts, 360.0).shape[0] == 4
