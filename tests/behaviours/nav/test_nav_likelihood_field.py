"""The likelihood field against a brute-force computation on a small map."""

from __future__ import annotations

import math

import numpy as np
import pytest

from behaviours.nav.distance_field import DistanceField
from behaviours.nav.grid import Grid
from behaviours.nav.localisation.likelihood_field import (
    BeamModel,
    DistanceGrid,
    LikelihoodField,
    select_beams,
)
from hal.readings import LidarScan

RES = 0.1


def _small_map(seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    occ = rng.random((12, 15)) < 0.08
    occ[0, :] = occ[-1, :] = occ[:, 0] = occ[:, -1] = True
    return occ


def _brute_distance(occ: np.ndarray, x: float, y: float, origin: tuple[float, float]) -> float:
    """Distance from the centre of the cell holding (x, y) to the nearest occupied centre."""
    col = math.floor((x - origin[0]) / RES)
    row = math.floor((y - origin[1]) / RES)
    rows, cols = np.nonzero(occ)
    return float(np.min(np.hypot(rows - row, cols - col))) * RES


class TestDistanceGrid:
    def test_distances_match_brute_force(self) -> None:
        """Every cell's distance is the Euclidean distance to the nearest occupied centre."""
        occ = _small_map(1)
        g = DistanceGrid.from_occupancy(occ, RES, -0.3, 0.2)
        rows, cols = np.nonzero(occ)
        for r in range(occ.shape[0]):
            for c in range(occ.shape[1]):
                want = float(np.min(np.hypot(rows - r, cols - c))) * RES
                assert g.distance_m[r, c] == pytest.approx(want, abs=1e-4)

    def test_the_planners_field_gives_the_same_grid(self) -> None:
        """DistanceGrid.from_field (nav-plan's DistanceField) equals from_occupancy."""
        occ = _small_map(2)
        ours = DistanceGrid.from_occupancy(occ, RES, 1.0, -2.0)
        theirs = DistanceGrid.from_field(DistanceField(Grid(occ, RES, 1.0, -2.0)))
        assert np.allclose(ours.distance_m, theirs.distance_m, atol=1e-5)
        assert (theirs.origin_x_m, theirs.origin_y_m) == (1.0, -2.0)


class TestLikelihoodField:
    @pytest.mark.parametrize("combine", ["product", "cube_sum"])
    def test_weights_match_brute_force(self, combine: str) -> None:
        """Per particle: product of pz (scaled to the best) or 1 + sum pz^3, as written out."""
        occ = _small_map(3)
        origin = (-0.5, 0.25)
        model = BeamModel(z_hit=0.6, z_rand=0.4, sigma_hit_m=0.15, max_dist_m=0.35,
                          max_range_m=5.0, combine=combine)
        field = LikelihoodField(DistanceGrid.from_occupancy(occ, RES, *origin), model)
        rng = np.random.default_rng(4)
        particles = np.column_stack((rng.uniform(-0.4, 0.9, 30), rng.uniform(0.3, 1.3, 30),
                                     rng.uniform(-math.pi, math.pi, 30)))
        beams = rng.uniform(-0.8, 0.8, (7, 2))
        factors, _ = field.weights(particles, beams)
        want = []
        for x, y, t in particles:
            scores = []
            for bx, by in beams:
                ex = x + math.cos(t) * bx - math.sin(t) * by
                ey = y + math.sin(t) * bx + math.cos(t) * by
                inside = (0 <= (ex - origin[0]) / RES < occ.shape[1]
                          and 0 <= (ey - origin[1]) / RES < occ.shape[0])
                z = min(_brute_distance(occ, ex, ey, origin), 0.35) if inside else 0.35
                pz = 0.6 * math.exp(-z * z / (2 * 0.15**2)) + 0.4 / 5.0
                scores.append(math.log(pz) if combine == "product" else pz**3)
            want.append(sum(scores) if combine == "product" else 1 + sum(scores))
        expect = np.array(want)
        if combine == "product":
            expect = np.exp(expect - expect.max())
        assert np.allclose(factors, expect, rtol=1e-6)

    def test_the_true_pose_outweighs_a_shifted_one(self) -> None:
        """Beams cast from a pose score higher there than 10 cm or 5 degrees away."""
        occ = np.zeros((40, 40), dtype=bool)
        occ[0, :] = occ[-1, :] = occ[:, 0] = occ[:, -1] = True
        occ[10:14, 25:30] = True
        field = LikelihoodField(DistanceGrid.from_occupancy(occ, RES, 0.0, 0.0), BeamModel())
        pose = np.array([1.5, 2.0, 0.3])
        x, y = np.nonzero(occ.T)  # occupied centres as the scan's end points
        ends = np.column_stack(((x + 0.5) * RES, (y + 0.5) * RES))[::7]
        c, s = math.cos(-pose[2]), math.sin(-pose[2])
        d = ends - pose[:2]
        beams = np.column_stack((c * d[:, 0] - s * d[:, 1], s * d[:, 0] + c * d[:, 1]))
        shift = np.array([[0, 0, 0], [0.1, 0, 0], [0, 0, math.radians(5)]])
        candidates = pose + shift
        factors, _ = field.weights(candidates, beams)
        assert factors[0] == factors.max()
        assert factors[1] < 0.5 and factors[2] < 0.5

    def test_beam_selection_skips_missing_returns_and_caps_the_count(self) -> None:
        """At most max_beams beams; NaN and too-long ranges are left out, not replaced."""
        angles = np.linspace(-math.pi, math.pi, 450, endpoint=False)
        ranges = np.full(450, 2.0)
        ranges[::2] = np.nan
        ranges[1::4] = 20.0
        scan = LidarScan(angles, ranges, np.zeros(450, dtype=np.uint8), 0.0)
        beams = select_beams(scan, 60, 12.0)
        assert 0 < beams.shape[0] < 60
        assert select_beams(LidarScan(angles, np.full(450, 2.0), scan.intensities, 0.0), 60,
                            12.0).shape[0] == 60
        assert np.allclose(np.hypot(beams[:, 0], beams[:, 1]), 2.0)
