"""Low-variance resampling, KLD sample counts and augmented-MCL recovery."""

from __future__ import annotations

import math
from statistics import NormalDist

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from behaviours.nav.localisation.kld import adaptive_count, kld_limit
from behaviours.nav.localisation.particles import ParticleSet, low_variance_indices

weights_st = st.lists(st.floats(0.0, 1.0, allow_nan=False), min_size=1, max_size=60).filter(
    lambda w: sum(w) > 1e-6)


class TestLowVarianceResampling:
    @settings(max_examples=200)
    @given(weights_st, st.integers(1, 500), st.integers(0, 2**32 - 1))
    def test_each_particle_is_drawn_floor_or_ceil_of_its_share(
            self, weights: list[float], count: int, seed: int) -> None:
        """Particle i is drawn floor(count w_i) or ceil(count w_i) times (systematic)."""
        w = np.array(weights)
        idx = low_variance_indices(w, count, np.random.default_rng(seed))
        drawn = np.bincount(idx, minlength=w.shape[0])
        share = count * w / w.sum()
        assert drawn.sum() == count
        assert np.all(drawn >= np.floor(share - 1e-9)) and np.all(drawn <= np.ceil(share + 1e-9))

    def test_expected_draws_equal_the_weights(self) -> None:
        """Averaged over many offsets, the draws per particle are count x weight."""
        w = np.array([0.05, 0.5, 0.013, 0.237, 0.2])
        rng = np.random.default_rng(5)
        total = np.zeros(5)
        runs = 4000
        for _ in range(runs):
            total += np.bincount(low_variance_indices(w, 7, rng), minlength=5)
        assert np.allclose(total / runs, 7 * w, atol=0.05)

    def test_resampling_keeps_the_weighted_mean(self) -> None:
        """The resampled set's mean is the weighted mean before (a few mm at 2000)."""
        rng = np.random.default_rng(6)
        poses = np.column_stack((rng.normal(2, 0.3, 3000), rng.normal(-1, 0.3, 3000),
                                 rng.normal(0.2, 0.1, 3000)))
        ps = ParticleSet(poses)
        ps.weights = rng.random(3000)
        ps.weights /= ps.weights.sum()
        before = ps.weights @ poses
        ps.resample(rng, lambda n: np.zeros((n, 3)), kld_err=0.05, kld_z=0.99,
                    min_particles=2000, max_particles=2000, recover=False)
        assert len(ps) == 2000
        assert np.allclose(ps.poses.mean(axis=0), before, atol=0.02)


class TestKld:
    @given(st.integers(1, 5000))
    def test_limit_stays_in_bounds_and_grows_with_bins(self, k: int) -> None:
        """min <= limit(k) <= max, and limit(k + 1) >= limit(k)."""
        a, b = kld_limit([k, k + 1], 0.05, 0.99, 100, 5000)
        assert 100 <= a <= b <= 5000

    def test_limit_is_fox_formula(self) -> None:
        """k = 50, eps 0.05, z(0.99): (k-1)/(2 eps) (1 - 2/(9(k-1)) + sqrt(2/(9(k-1))) z)^3."""
        z = NormalDist().inv_cdf(0.99)
        b = 2 / (9 * 49)
        want = math.ceil(49 / 0.1 * (1 - b + math.sqrt(b) * z) ** 3)
        assert int(kld_limit(50, 0.05, 0.99, 1, 100000)) == want

    def test_a_tight_cloud_needs_the_minimum_and_a_wide_one_the_maximum(self) -> None:
        """Poses in one bin: min_particles; poses over a room: max_particles."""
        rng = np.random.default_rng(7)
        tight = np.column_stack((rng.uniform(0.1, 0.4, 2000), rng.uniform(0.1, 0.4, 2000),
                                 rng.uniform(0.01, 0.1, 2000)))
        wide = np.column_stack((rng.uniform(0, 10, 2000), rng.uniform(0, 10, 2000),
                                rng.uniform(-3, 3, 2000)))
        assert adaptive_count(tight, 0.05, 0.99, 500, 2000) == 500
        assert adaptive_count(wide, 0.05, 0.99, 500, 2000) == 2000


class TestRecovery:
    def test_a_sudden_drop_in_likelihood_draws_random_poses(self) -> None:
        """w_fast falling below w_slow replaces a share of the draws by free-space poses."""
        rng = np.random.default_rng(8)
        ps = ParticleSet(np.zeros((1000, 3)))
        for _ in range(50):
            ps.weigh(np.ones(1000), np.full(1000, 0.5), 0.001, 0.1)
        for _ in range(5):
            ps.weigh(np.ones(1000), np.full(1000, 0.05), 0.001, 0.1)
        assert ps.w_fast < ps.w_slow
        ps.resample(rng, lambda n: np.full((n, 3), 9.0), kld_err=0.05, kld_z=0.99,
                    min_particles=1000, max_particles=1000, recover=True)
        assert ps.random_drawn > 100
        assert np.count_nonzero(ps.poses[:, 0] == 9.0) == ps.random_drawn
        assert ps.w_slow == ps.w_fast == 0.0

    def test_a_steady_likelihood_draws_none(self) -> None:
        """Steady measurements: w_fast = w_slow, no random poses."""
        ps = ParticleSet(np.zeros((500, 3)))
        for _ in range(20):
            ps.weigh(np.ones(500), np.full(500, 0.5), 0.001, 0.1)
        ps.resample(np.random.default_rng(9), lambda n: np.full((n, 3), 9.0), kld_err=0.05,
                    kld_z=0.99, min_particles=500, max_particles=500, recover=True)
        assert ps.random_drawn == 0
