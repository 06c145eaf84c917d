"""The localiser in a small room: tracking, global start, kidnap, LiDAR loss, determinism."""

from __future__ import annotations

import math

import numpy as np
import pytest
from nav_room import drive, grid, odometry_of, scan_at

from behaviours.nav.localisation.config import LocalisationConfig
from behaviours.nav.localisation.filter import (
    DIVERGED,
    LIDAR_LOST,
    LOCALISED,
    ODOMETRY_ONLY,
    Localiser,
)
from behaviours.nav.localisation.likelihood_field import DistanceGrid
from hal.readings import LidarScan

SCAN_PERIOD_S = 0.1
ROUTE = [(2.0, 0.5, 0.0), (3.5, 0.6, 0.0), (3.5, 0.6, 1.57), (3.5, 3.0, 1.57),
         (3.5, 3.0, 3.14), (0.8, 2.6, 3.14)]


def _errors(loc: Localiser, truth: list[tuple[float, float, float]],
            odom: list[tuple[float, float, float]], rng: np.random.Generator,
            start_i: int = 0) -> list[tuple[float, float]]:
    """Run the scans along a path; (position error m, heading error deg) after each."""
    out = []
    for i, (t, o) in enumerate(zip(truth, odom, strict=True)):
        loc.on_scan(o, scan_at(t, rng), (start_i + i) * SCAN_PERIOD_S)
        p = loc.pose_array(o)
        out.append((math.hypot(p[0] - t[0], p[1] - t[1]),
                    abs(math.degrees(math.remainder(p[2] - t[2], 2 * math.pi)))))
    return out


@pytest.fixture(scope="module")
def room_grid() -> DistanceGrid:
    return grid()


class TestTracking:
    def test_from_a_rough_start_it_tracks_within_5_cm_and_3_degrees(
            self, room_grid: DistanceGrid) -> None:
        """Start 14 cm / 3 deg off, 2-3 % odometry error: after 10 updates, p95 < 5 cm / 3 deg."""
        rng = np.random.default_rng(11)
        loc = Localiser(room_grid, LocalisationConfig())
        loc.start_at(2.1, 0.4, 0.05)
        truth = drive(ROUTE)
        errors = _errors(loc, truth, odometry_of(truth, rng), rng)
        after = [e for e, n in zip(errors, range(len(errors)), strict=True)
                 if n >= 50]  # 50 scans = 2.5 m driven, 10 updates
        pos = np.percentile([e[0] for e in after], 95)
        head = np.percentile([e[1] for e in after], 95)
        assert pos < 0.05 and head < 3.0, (pos, head)
        assert loc.status == LOCALISED

    def test_between_scans_the_pose_follows_odometry(self, room_grid: DistanceGrid) -> None:
        """The fused pose is the last correction composed with the odometry of the moment."""
        rng = np.random.default_rng(12)
        loc = Localiser(room_grid, LocalisationConfig())
        loc.start_at(2.0, 0.5, 0.0, 0.05, 0.05)
        loc.on_scan((0.0, 0.0, 0.0), scan_at((2.0, 0.5, 0.0), rng), 0.0)
        before = loc.pose_array((0.0, 0.0, 0.0))
        after = loc.pose_array((0.1, 0.0, 0.0))  # 10 cm on odometry, no scan
        assert math.hypot(*(after[:2] - before[:2])) == pytest.approx(0.1, abs=1e-9)


class TestGlobalStart:
    @pytest.mark.parametrize("seed", [0, 1, 2, 3])
    def test_global_start_finds_the_one_answer(self, room_grid: DistanceGrid, seed: int) -> None:
        """Particles over the whole free space, a turn on the spot: within 5 cm and 3 deg."""
        starts = [(3.0, 3.0, 1.0), (1.0, 4.5, -1.5), (5.5, 3.5, 3.0), (0.5, 2.0, 0.3)]
        s = starts[seed]
        rng = np.random.default_rng(seed)
        loc = Localiser(room_grid, LocalisationConfig(seed=seed))
        loc.start_global()
        truth = drive([s, (s[0], s[1], s[2] + 2.0)], step_rad=0.25)
        errors = _errors(loc, truth, odometry_of(truth, rng), rng)
        assert errors[-1][0] < 0.05 and errors[-1][1] < 3.0, errors[-1]


class TestDivergence:
    @pytest.mark.parametrize("seed", [13, 14, 15])
    def test_a_kidnap_of_1_m_is_reported_within_10_s(self, room_grid: DistanceGrid,
                                                     seed: int) -> None:
        """Teleport the robot 1 m mid-route (odometry does not see it): diverged within 10 s."""
        rng = np.random.default_rng(seed)
        loc = Localiser(room_grid, LocalisationConfig(seed=seed))
        loc.start_at(2.0, 0.5, 0.0, 0.05, 0.05)
        truth = drive([*ROUTE[:5], (2.3, 2.8, 3.14)])
        odom = odometry_of(truth, rng)
        kidnap_i = 50  # driving up the x = 3.5 leg
        _errors(loc, truth[:kidnap_i], odom[:kidnap_i], rng)
        assert loc.status == LOCALISED
        moved = [(x - 1.0, y, t) for x, y, t in truth[kidnap_i:]]
        diverged_at = None
        for i, (t, o) in enumerate(zip(moved, odom[kidnap_i:], strict=True)):
            now = (kidnap_i + i) * SCAN_PERIOD_S
            loc.on_scan(o, scan_at(t, rng), now)
            if loc.status == DIVERGED:
                diverged_at = now - kidnap_i * SCAN_PERIOD_S
                break
        assert diverged_at is not None and diverged_at <= 10.0, diverged_at
        assert loc.divergences == 1


class TestLidarLoss:
    def test_odometry_only_for_a_bounded_time_then_an_error(self, room_grid: DistanceGrid) -> None:
        """Stale LiDAR: odometry_only, then lidar_lost after lidar_lost_max_s; a scan heals."""
        rng = np.random.default_rng(14)
        loc = Localiser(room_grid, LocalisationConfig(lidar_lost_max_s=30.0))
        loc.start_at(2.0, 0.5, 0.0, 0.05, 0.05)
        loc.on_scan((0, 0, 0), scan_at((2.0, 0.5, 0.0), rng), 0.0)
        loc.lidar_stale(1.0)
        assert loc.status == ODOMETRY_ONLY
        loc.lidar_stale(30.5)
        assert loc.status == ODOMETRY_ONLY
        loc.lidar_stale(31.0)
        assert loc.status == LIDAR_LOST
        loc.on_scan((0, 0, 0), scan_at((2.0, 0.5, 0.0), rng), 32.0)
        assert loc.status == LOCALISED


class TestDeterminism:
    def _run(self, room_grid: DistanceGrid, seed: int) -> np.ndarray:
        rng = np.random.default_rng(99)  # the same scans and odometry every run
        loc = Localiser(room_grid, LocalisationConfig(seed=seed))
        loc.start_at(2.1, 0.4, 0.05)
        truth = drive(ROUTE[:3])
        odom = odometry_of(truth, rng)
        _errors(loc, truth, odom, rng)
        return np.vstack((loc.particles.poses[:5], loc.pose_array(odom[-1])))

    def test_the_same_seed_gives_the_same_poses(self, room_grid: DistanceGrid) -> None:
        """Same seed and inputs: identical particles and pose; another seed: different."""
        a, b = self._run(room_grid, 5), self._run(room_grid, 5)
        assert np.array_equal(a, b)
        assert not np.array_equal(a, self._run(room_grid, 6))


class TestDeferredResampling:
    def _run(self, room_grid: DistanceGrid, *, defer: bool) -> list[np.ndarray]:
        rng = np.random.default_rng(99)
        loc = Localiser(room_grid, LocalisationConfig(seed=5))
        loc.start_at(2.1, 0.4, 0.05)
        truth = drive(ROUTE[:3])
        odom = odometry_of(truth, rng)
        poses = []
        for i, (t, o) in enumerate(zip(truth, odom, strict=True)):
            loc.on_scan(o, scan_at(t, rng), i * SCAN_PERIOD_S, defer_resample=defer)
            poses.append(loc.pose_array(o))
            if i == 20:
                loc.start_at(*t)  # a restart with a resampling owed
            if defer and i % 2:
                loc.finish_update()  # every other scan: the next on_scan finishes the rest
        loc.finish_update()
        return [*poses, loc.particles.poses]

    def test_resampling_in_a_later_step_changes_nothing(self, room_grid: DistanceGrid) -> None:
        """on_scan(defer_resample=True) then finish_update() (the localisation service's two
        loop steps), or the next scan or a restart coming first: the same poses and
        particles, to the bit, as resampling within on_scan."""
        at_once, deferred = (self._run(room_grid, defer=d) for d in (False, True))
        assert len(at_once) == len(deferred)
        for a, b in zip(at_once, deferred, strict=True):
            assert np.array_equal(a, b)


class TestBadInput:
    def test_a_malformed_scan_is_counted_not_raised(self, room_grid: DistanceGrid) -> None:
        """Angles and ranges of different lengths, or a NaN odometry pose: skipped, counted."""
        rng = np.random.default_rng(15)
        loc = Localiser(room_grid, LocalisationConfig())
        loc.start_at(2.0, 0.5, 0.0, 0.05, 0.05)
        good = scan_at((2.0, 0.5, 0.0), rng)
        bad = LidarScan(good.angles_rad[:10], good.ranges_m, good.intensities, 0.0)
        assert loc.on_scan((0.0, 0.0, 0.0), bad, 0.0) is False
        assert loc.on_scan((math.nan, 0.0, 0.0), good, 0.1) is False
        assert loc.rejected == 2 and loc.scans == 0
        assert loc.on_scan((0.0, 0.0, 0.0), good, 0.2) is True
