"""Scan-to-map fit: correlative search + ICP finds the pose, and refuses to guess in a
symmetric room."""

from __future__ import annotations

import math

import numpy as np
import pytest

from behaviours.nav.distance_field import DistanceField
from behaviours.nav.grid import Grid
from behaviours.nav.icp import Walls, icp
from behaviours.nav.scan_match import MatchConfig, ScanMatcher, distinct
from sim.world.geometry import raycast

Seg = tuple[float, float, float, float]


def box(x: float, y: float, w: float, h: float) -> list[Seg]:
    return [(x, y, x + w, y), (x + w, y, x + w, y + h), (x + w, y + h, x, y + h),
            (x, y + h, x, y)]


SQUARE = box(0, 0, 4, 4)
ROOM = [*box(0, 0, 6, 4), *box(5.2, 3.2, 0.8, 0.8), *box(0, 0, 0.5, 1.2)]


def matcher(walls: list[Seg], **config: float) -> ScanMatcher:
    grid = Grid.from_segments(walls, 0.05)
    return ScanMatcher(DistanceField(grid), np.asarray(walls), MatchConfig(**config))


def scan(walls: list[Seg], pose: tuple[float, float, float], *, noise_m: float = 0.0,
         seed: int = 0) -> np.ndarray:
    angles = np.linspace(0, 2 * math.pi, 360, endpoint=False)
    ranges = raycast(np.asarray(walls, dtype=np.float64), pose[0], pose[1], angles + pose[2],
                     10.0)
    ranges = ranges + np.random.default_rng(seed).normal(0, noise_m, ranges.shape)
    return np.stack([ranges * np.cos(angles), ranges * np.sin(angles)], axis=1)


def error(a: tuple[float, float, float], b: tuple[float, float, float]) -> tuple[float, float]:
    d = math.atan2(math.sin(a[2] - b[2]), math.cos(a[2] - b[2]))
    return math.hypot(a[0] - b[0], a[1] - b[1]), abs(math.degrees(d))


class TestLocalFit:
    def test_finds_the_pose_from_a_rough_guess(self) -> None:
        """From 0.25 m and 15 degrees off, the fit is within 1 cm and 0.3 degrees."""
        truth = (2.3, 1.9, 0.4)
        fit = matcher(ROOM).fit_local(scan(ROOM, truth, noise_m=0.01),
                                      (2.1, 2.05, 0.4 + math.radians(15)))
        assert fit.accepted, fit.reason
        e_m, e_deg = error(fit.pose, truth)
        assert e_m < 0.01
        assert e_deg < 0.3

    def test_too_few_points_is_refused(self) -> None:
        """A scan with almost no points is refused and says so."""
        fit = matcher(ROOM).fit_local(np.zeros((3, 2)), (1.0, 1.0, 0.0))
        assert not fit.accepted
        assert "too few scan points" in fit.reason

    def test_a_scan_of_another_place_is_refused(self) -> None:
        """A scan from a round room does not fit the rectangular map: low score, refused."""
        angles = np.linspace(0, 2 * math.pi, 360, endpoint=False)
        circle = np.stack([1.3 * np.cos(angles), 1.3 * np.sin(angles)], axis=1)
        fit = matcher(ROOM).fit_local(circle, (3.0, 2.0, 0.0))
        assert not fit.accepted
        assert "below fit_min_score" in fit.reason


class TestGlobalFit:
    def test_an_asymmetric_room_is_found_at_any_heading(self) -> None:
        """With the room's corner features the global fit finds the pose, every heading."""
        m = matcher(ROOM)
        for k, heading in enumerate((0.0, 1.7, -2.5)):
            truth = (2.0 + 0.4 * k, 2.2 - 0.3 * k, heading)
            fit = m.fit_global(scan(ROOM, truth, noise_m=0.01, seed=k), (0, 0, 6, 4))
            assert fit.accepted, fit.reason
            e_m, e_deg = error(fit.pose, truth)
            assert e_m < 0.02
            assert e_deg < 0.5

    def test_a_symmetric_room_is_ambiguous_not_confidently_wrong(self) -> None:
        """In a bare square room every quarter turn fits as well: refused as ambiguous,
        with the rival pose named."""
        truth = (1.6, 2.1, 0.3)
        fit = matcher(SQUARE).fit_global(scan(SQUARE, truth, noise_m=0.01), (0, 0, 4, 4))
        assert not fit.accepted
        assert fit.reason.startswith("ambiguous")
        assert fit.rival_pose is not None
        assert distinct(fit.pose, fit.rival_pose, 0.5, math.radians(30))
        assert fit.rival_score == pytest.approx(fit.score, abs=0.05)

    def test_the_square_room_with_one_feature_is_found(self) -> None:
        """The same square with a 1 m block in one corner is no longer ambiguous (a 0.6 m
        block is: only a few beams tell the corners apart, less than the margin)."""
        walls = [*SQUARE, *box(3.0, 3.0, 1.0, 1.0)]
        truth = (1.6, 2.1, 0.3)
        fit = matcher(walls).fit_global(scan(walls, truth, noise_m=0.01), (0, 0, 4, 4))
        assert fit.accepted, fit.reason
        assert error(fit.pose, truth)[0] < 0.02


class TestIcp:
    def test_icp_pulls_a_near_pose_onto_the_walls(self) -> None:
        """From 4 cm and 1 degree off, point-to-line ICP lands within 2 mm."""
        truth = (2.0, 1.5, 0.2)
        pose = icp(scan(ROOM, truth), Walls.of(np.asarray(ROOM)),
                   (2.03, 1.47, 0.2 + math.radians(1)))
        e_m, e_deg = error(pose, truth)
        assert e_m < 0.002
        assert e_deg < 0.05
