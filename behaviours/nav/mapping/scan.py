"""One laser scan with the odometry pose it was taken at, and planar pose algebra (SE(2)).

Poses are ``(x_m, y_m, theta_rad)`` tuples, the same ``Pose`` the scan matcher and ICP use.
``compose(a, b)`` is ``a ⊕ b`` (b expressed in a's frame, put in the world), ``between(a, b)``
is ``a⁻¹ ⊕ b`` (b seen from a): an odometry step or a pose-graph edge.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from behaviours.motion.moves import wrap
from behaviours.nav.icp import Pose

FloatArray = npt.NDArray[np.float64]


def compose(a: Pose, b: Pose) -> Pose:
    c, s = math.cos(a[2]), math.sin(a[2])
    return (a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], wrap(a[2] + b[2]))


def between(a: Pose, b: Pose) -> Pose:
    c, s = math.cos(a[2]), math.sin(a[2])
    dx, dy = b[0] - a[0], b[1] - a[1]
    return (c * dx + s * dy, -s * dx + c * dy, wrap(b[2] - a[2]))


@dataclass(frozen=True, slots=True)
class Scan:
    """A scan in the sensor's frame (beam i at ``angle_min_rad + i * angle_increment_rad``,
    counter-clockwise); a range that is not finite, <= 0 or >= ``max_range_m`` is no return.

    ``odom`` is the robot's odometry pose when it was taken; the laser sits at ``laser_offset``
    in the robot's frame (CARMEN logs give both poses)."""

    timestamp_s: float
    ranges_m: FloatArray
    angle_min_rad: float
    angle_increment_rad: float
    max_range_m: float
    odom: Pose
    laser_offset: Pose = (0.0, 0.0, 0.0)
    beam_angles_rad: FloatArray | None = None
    """Each beam's own angle, for a sensor whose beams are not evenly spaced (the LD19's
    turn as its driver assembles it); None: ``angle_min_rad + i * angle_increment_rad``."""

    def returns(self) -> npt.NDArray[np.bool_]:
        r = self.ranges_m
        return np.isfinite(r) & (r > 0.0) & (r < self.max_range_m)

    def angles_rad(self) -> FloatArray:
        if self.beam_angles_rad is not None:
            return self.beam_angles_rad
        out: FloatArray = (self.angle_min_rad
                           + self.angle_increment_rad * np.arange(self.ranges_m.size,
                                                                  dtype=np.float64))
        return out

    def points(self) -> FloatArray:
        """The returns as (N, 2) points in the robot's frame (the laser's offset applied)."""
        keep = self.returns()
        a = self.angles_rad()[keep] + self.laser_offset[2]
        r = self.ranges_m[keep]
        lx, ly = self.laser_offset[0], self.laser_offset[1]
        out: FloatArray = np.column_stack((lx + r * np.cos(a), ly + r * np.sin(a)))
        return out
