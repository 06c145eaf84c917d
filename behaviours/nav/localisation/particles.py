"""The particle set: weights, low-variance resampling with KLD and augmented-MCL recovery.

Particles are an (n, 3) array of map poses; weights sum to 1. Everything is drawn from the
``numpy.random.Generator`` passed in, so a filter is deterministic for a seed.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from behaviours.nav.localisation.kld import BIN_THETA_RAD, BIN_XY_M, adaptive_count
from behaviours.nav.localisation.motion_model import wrap

FloatArray = npt.NDArray[np.float64]
PoseSampler = Callable[[int], FloatArray]
"""Draws n poses uniformly over where the robot may be (the map's free space)."""


def low_variance_indices(weights: FloatArray, count: int, rng: np.random.Generator
                         ) -> npt.NDArray[np.intp]:
    """Systematic (low-variance) resampling: ``count`` indices, one random offset.

    Particle i is drawn floor(count w_i) or ceil(count w_i) times, so its expected share is
    its weight and the variance is the least any unbiased resampler has.
    """
    total = float(weights.sum())
    if count <= 0 or total <= 0 or not math.isfinite(total):
        return np.zeros(0, dtype=np.intp)
    cumulative = np.cumsum(weights) / total
    cumulative[-1] = 1.0
    points = (rng.random() + np.arange(count)) / count
    found: npt.NDArray[np.intp] = np.searchsorted(cumulative, points, side="right")
    result: npt.NDArray[np.intp] = np.minimum(found, weights.shape[0] - 1)
    return result


@dataclass(frozen=True, slots=True)
class Estimate:
    """The filter's pose and how sure it is (std of position and heading)."""

    x_m: float
    y_m: float
    theta_rad: float
    spread_m: float
    spread_rad: float

    def as_array(self) -> FloatArray:
        return np.array([self.x_m, self.y_m, self.theta_rad])


class ParticleSet:
    """Particles, their weights and AMCL's slow/fast likelihood averages."""

    def __init__(self, poses: FloatArray) -> None:
        self.poses = poses
        self.weights = np.full(poses.shape[0], 1.0 / max(1, poses.shape[0]))
        self.w_slow = 0.0
        self.w_fast = 0.0
        self.random_drawn = 0

    def __len__(self) -> int:
        return int(self.poses.shape[0])

    def weigh(self, factors: FloatArray, likelihoods: FloatArray, alpha_slow: float,
              alpha_fast: float) -> float:
        """Multiply in a sensor's factors and normalise; update the slow and fast averages of
        the measurement likelihood (weighted by the prior weights). Returns that average."""
        w_avg = float(np.dot(self.weights, likelihoods))
        weighted = self.weights * factors
        total = float(weighted.sum())
        if total <= 0 or not math.isfinite(total):
            self.weights = np.full(len(self), 1.0 / len(self))
            return 0.0
        self.weights = weighted / total
        if self.w_slow == 0.0:
            self.w_slow = w_avg
        else:
            self.w_slow += alpha_slow * (w_avg - self.w_slow)
        if self.w_fast == 0.0:
            self.w_fast = w_avg
        else:
            self.w_fast += alpha_fast * (w_avg - self.w_fast)
        return w_avg

    def resample(self, rng: np.random.Generator, sample_free: PoseSampler, *,
                 kld_err: float, kld_z: float, min_particles: int, max_particles: int,
                 recover: bool) -> None:
        """Draw the next set: low-variance over the weights, KLD-sized, some random poses.

        ``max_particles`` are drawn systematically and shuffled (so any prefix is an unbiased
        sample of them); with probability ``1 - w_fast / w_slow`` (augmented MCL) a draw is
        replaced by a random free-space pose; KLD sampling then keeps the prefix its bins
        need. As in AMCL, a recovery resets both averages.
        """
        w_diff = 0.0
        if recover and self.w_slow > 0.0:
            w_diff = max(0.0, 1.0 - self.w_fast / self.w_slow)
        picks = low_variance_indices(self.weights, max_particles, rng)
        drawn = self.poses[rng.permutation(picks)]
        replace = rng.random(max_particles) < w_diff
        n_random = int(np.count_nonzero(replace))
        if n_random:
            drawn[replace] = sample_free(n_random)
        count = adaptive_count(drawn, kld_err, kld_z, min_particles, max_particles)
        self.poses = drawn[:count].copy()
        self.weights = np.full(count, 1.0 / count)
        self.random_drawn = int(np.count_nonzero(replace[:count]))
        if w_diff > 0.0:
            self.w_slow = self.w_fast = 0.0

    def estimate(self) -> Estimate:
        """The weighted mean of the heaviest cluster, and the whole set's spread.

        AMCL reports its heaviest cluster; here the cluster is the particles within 1 m and
        30 degrees of the heaviest histogram bin's mean, enough to keep a second mode
        (global start, symmetric rooms) out of the mean.
        """
        poses, w = self.poses, self.weights
        keys = (np.floor(poses[:, 0] / BIN_XY_M).astype(np.int64) * 1_000_003
                + np.floor(poses[:, 1] / BIN_XY_M).astype(np.int64) * 101
                + np.floor(poses[:, 2] / BIN_THETA_RAD).astype(np.int64))
        uniq, inv = np.unique(keys, return_inverse=True)
        heaviest = int(np.argmax(np.bincount(inv, weights=w, minlength=uniq.shape[0])))
        seed = _weighted_mean(poses[inv == heaviest], w[inv == heaviest])
        near = ((np.hypot(poses[:, 0] - seed[0], poses[:, 1] - seed[1]) < 1.0)
                & (np.abs(wrap(poses[:, 2] - seed[2])) < math.radians(30)))
        mean = _weighted_mean(poses[near], w[near])
        whole = _weighted_mean(poses, w)
        var_xy = float(np.sum(w * ((poses[:, 0] - whole[0]) ** 2
                                   + (poses[:, 1] - whole[1]) ** 2)) / np.sum(w))
        resultant = float(np.hypot(np.sum(w * np.cos(poses[:, 2])),
                                   np.sum(w * np.sin(poses[:, 2]))) / np.sum(w))
        spread_rad = math.sqrt(max(0.0, -2.0 * math.log(max(resultant, 1e-12))))
        return Estimate(float(mean[0]), float(mean[1]), float(mean[2]),
                        math.sqrt(max(0.0, var_xy)), spread_rad)


def _weighted_mean(poses: FloatArray, w: FloatArray) -> FloatArray:
    total = float(w.sum())
    if total <= 0:
        w = np.ones(poses.shape[0])
        total = float(poses.shape[0])
    x = float(np.dot(w, poses[:, 0]) / total)
    y = float(np.dot(w, poses[:, 1]) / total)
    theta = math.atan2(float(np.dot(w, np.sin(poses[:, 2]))),
                       float(np.dot(w, np.cos(poses[:, 2]))))
    return np.array([x, y, theta])
