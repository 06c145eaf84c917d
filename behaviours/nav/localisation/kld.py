"""KLD sampling (Fox 2001): how many particles a posterior spread over k histogram bins needs.

Bins are 0.5 m x 0.5 m x 10 degrees, as AMCL's ``pf_kdtree`` cells. The count is
``(k - 1) / (2 eps) * (1 - 2/(9(k-1)) + sqrt(2/(9(k-1))) z)^3`` clamped to the limits; ``z`` is
the upper standard normal quantile of ``kld_z`` (AMCL's ``pf.c`` puts 0.99 itself in for z,
which asks for about four times fewer particles than the formula means; we take the quantile,
2.33, and let ``max_particles`` bound the cost). One bin needs ``min_particles``: the formula
gives 0 there, and ``pf.c``'s answer, ``max_particles``, would make a filter that has
converged into one bin the most expensive one.
"""

from __future__ import annotations

import math
from statistics import NormalDist

import numpy as np
import numpy.typing as npt

BIN_XY_M = 0.5
BIN_THETA_RAD = math.radians(10.0)


def kld_limit(bins: npt.ArrayLike, kld_err: float, kld_z: float, min_particles: int,
              max_particles: int) -> npt.NDArray[np.int64]:
    """Particles needed for ``bins`` occupied bins (an int or an array of them)."""
    k = np.asarray(bins, dtype=np.float64)
    z = NormalDist().inv_cdf(kld_z)
    with np.errstate(divide="ignore", invalid="ignore"):
        b = 2.0 / (9.0 * (k - 1.0))
        n = (k - 1.0) / (2.0 * kld_err) * (1.0 - b + np.sqrt(b) * z) ** 3
    n = np.where(k <= 1, min_particles, np.ceil(n))
    return np.clip(n, min_particles, max_particles).astype(np.int64)


def bin_keys(poses: npt.NDArray[np.float64]) -> npt.NDArray[np.int64]:
    """One integer per histogram bin a pose falls in."""
    ix = np.floor(poses[:, 0] / BIN_XY_M).astype(np.int64)
    iy = np.floor(poses[:, 1] / BIN_XY_M).astype(np.int64)
    it = np.floor(poses[:, 2] / BIN_THETA_RAD).astype(np.int64)
    # 2^21 bins per axis: +-524 km at 0.5 m, far beyond any map; theta has 36 bins.
    return ((ix + (1 << 20)) << 27) | ((iy + (1 << 20)) << 6) | (it + 18)


def adaptive_count(poses: npt.NDArray[np.float64], kld_err: float, kld_z: float,
                   min_particles: int, max_particles: int) -> int:
    """How many of ``poses``, taken in order, KLD sampling keeps.

    As AMCL's resampling loop: draw one after another, counting the bins hit so far, and stop
    once the number drawn reaches the limit for those bins. Vectorised: the bins-so-far count
    after each draw is the running count of first occurrences.
    """
    if poses.shape[0] == 0:
        return 0
    keys = bin_keys(poses)
    _, first = np.unique(keys, return_index=True)
    new_bin = np.zeros(keys.shape[0], dtype=np.int64)
    new_bin[first] = 1
    k_so_far = np.cumsum(new_bin)
    limits = kld_limit(k_so_far, kld_err, kld_z, min_particles, max_particles)
    drawn = np.arange(1, keys.shape[0] + 1)
    done = np.nonzero(drawn >= limits)[0]
    return int(done[0] + 1) if done.size else int(keys.shape[0])
