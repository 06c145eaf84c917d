"""LiDAR-only localisation (encoders failed): the pose follows the robot on scans alone, and
the encoders' return does not move it."""

from __future__ import annotations

import math

import numpy as np
from nav_room import drive, grid, odometry_of, scan_at

from behaviours.nav.localisation.config import LocalisationConfig
from behaviours.nav.localisation.filter import LOCALISED, Localiser

ROUTE = [(2.0, 0.5, 0.0), (3.5, 0.6, 0.0), (3.5, 0.6, 1.57), (3.5, 3.0, 1.57),
         (3.5, 3.0, 3.14), (0.8, 2.6, 3.14)]


def test_frozen_odometry_tracks_on_scans_within_5_cm_and_returns_without_a_jump() -> None:
    """After 40 scans on odometry the odometry freezes: LiDAR-only keeps p95 < 5 cm / 3 deg
    over the rest of the route (2 cm a scan, a halved speed, with turns); switching back with
    the odometry jumped by (1 m, -0.5 m, 0.7 rad) leaves the map pose where it was."""
    rng = np.random.default_rng(5)
    loc = Localiser(grid(), LocalisationConfig())
    loc.start_at(2.0, 0.5, 0.0)
    truth = drive(ROUTE, step_m=0.02)
    odom = odometry_of(truth, rng)
    frozen_at = 40
    frozen = odom[frozen_at]
    errors = []
    for i, t in enumerate(truth):
        o = odom[i] if i < frozen_at else frozen
        if i == frozen_at:
            loc.set_lidar_only(True, frozen)
        loc.on_scan(o, scan_at(t, rng), i * 0.1)
        if i >= frozen_at + 3:
            p = loc.pose_array(o)
            errors.append((math.hypot(p[0] - t[0], p[1] - t[1]),
                           abs(math.degrees(math.remainder(p[2] - t[2], 2 * math.pi)))))
    pos = float(np.percentile([e[0] for e in errors], 95))
    head = float(np.percentile([e[1] for e in errors], 95))
    assert pos < 0.05 and head < 3.0, (pos, head)
    assert loc.status == LOCALISED
    before = loc.pose_array(frozen)
    jumped = (frozen[0] + 1.0, frozen[1] - 0.5, frozen[2] + 0.7)
    loc.set_lidar_only(False, jumped)
    assert np.allclose(loc.pose_array(jumped), before, atol=1e-9)
    assert loc.lidar_only is None
