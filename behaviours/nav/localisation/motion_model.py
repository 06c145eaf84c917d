"""Poses in the plane as (x, y, theta) arrays, and AMCL's odometry motion model.

A pose array has shape (..., 3): x and y in metres, theta in radians (counter-clockwise).
``compose(a, b)`` is "b expressed in a's frame, seen from the world"; the map<-odom
correction of the localiser is ``compose(map_pose, inverse(odom_pose))``.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]


def wrap(angle_rad: npt.ArrayLike) -> FloatArray:
    """Angles folded into [-pi, pi)."""
    return np.asarray((np.asarray(angle_rad, dtype=np.float64) + np.pi) % (2 * np.pi) - np.pi)


def compose(a: npt.ArrayLike, b: npt.ArrayLike) -> FloatArray:
    """a (+) b: pose b, given in a's frame, in the frame a is given in."""
    a_, b_ = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    c, s = np.cos(a_[..., 2]), np.sin(a_[..., 2])
    x = a_[..., 0] + c * b_[..., 0] - s * b_[..., 1]
    y = a_[..., 1] + s * b_[..., 0] + c * b_[..., 1]
    return np.stack((x, y, wrap(a_[..., 2] + b_[..., 2])), axis=-1)


def inverse(a: npt.ArrayLike) -> FloatArray:
    """The pose p with a (+) p = identity."""
    a_ = np.asarray(a, dtype=np.float64)
    c, s = np.cos(a_[..., 2]), np.sin(a_[..., 2])
    x = -c * a_[..., 0] - s * a_[..., 1]
    y = s * a_[..., 0] - c * a_[..., 1]
    return np.stack((x, y, wrap(-a_[..., 2])), axis=-1)


def relative(a: npt.ArrayLike, b: npt.ArrayLike) -> FloatArray:
    """(-)a (+) b: pose b seen from pose a."""
    return compose(inverse(a), b)


def _angle_noise(angle_rad: float) -> float:
    # AMCL: a bearing near +-pi is driving backwards, as small a turn as one near 0.
    return min(abs(math.remainder(angle_rad, 2 * math.pi)),
               abs(math.remainder(angle_rad - math.pi, 2 * math.pi)))


def sample_odometry_motion(
    particles: FloatArray,
    odom_from: tuple[float, float, float],
    odom_to: tuple[float, float, float],
    alphas: tuple[float, float, float, float],
    rng: np.random.Generator,
) -> FloatArray:
    """Move every particle by the odometry step ``odom_from`` -> ``odom_to``, with noise.

    Probabilistic Robotics' sample_motion_model_odometry as Nav2 AMCL's differential model
    has it: the step is a turn (rot1), a straight drive (trans) and a turn (rot2); each gets
    Gaussian noise whose variance is alpha-weighted squares of the step (alpha1: rotation
    from rotation, alpha2: rotation from translation, alpha3: translation from translation,
    alpha4: translation from rotation). A turn on the spot (trans < 1 cm) has no bearing.
    """
    dx, dy = odom_to[0] - odom_from[0], odom_to[1] - odom_from[1]
    trans = math.hypot(dx, dy)
    rot1 = 0.0 if trans < 0.01 else math.remainder(math.atan2(dy, dx) - odom_from[2],
                                                   2 * math.pi)
    rot2 = math.remainder(odom_to[2] - odom_from[2] - rot1, 2 * math.pi)
    n1, n2 = _angle_noise(rot1), _angle_noise(rot2)
    a1, a2, a3, a4 = alphas
    sd_rot1 = math.sqrt(a1 * n1 * n1 + a2 * trans * trans)
    sd_trans = math.sqrt(a3 * trans * trans + a4 * (n1 * n1 + n2 * n2))
    sd_rot2 = math.sqrt(a1 * n2 * n2 + a2 * trans * trans)
    count = particles.shape[0]
    noise = rng.standard_normal((3, count))
    rot1_hat = rot1 - sd_rot1 * noise[0]
    trans_hat = trans - sd_trans * noise[1]
    rot2_hat = rot2 - sd_rot2 * noise[2]
    heading = particles[:, 2] + rot1_hat
    out = np.empty_like(particles)
    out[:, 0] = particles[:, 0] + trans_hat * np.cos(heading)
    out[:, 1] = particles[:, 1] + trans_hat * np.sin(heading)
    out[:, 2] = wrap(heading + rot2_hat)
    return out
