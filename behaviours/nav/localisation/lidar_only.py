"""LiDAR-only localisation, for while the wheel encoders have failed (the seed's error table).

With the encoders frozen the odometry pose stands still while the robot moves, so the filter
cannot take its motion step from it. In this mode every scan updates the filter (no
``update_min_d_m`` gate: odometry would never say the robot moved), and the motion step
trusts no odometry at all: each particle is moved by the motion of the last LiDAR-only steps
(constant velocity, what the estimates themselves did, damped) and spread by Gaussian noise
wide enough for the (halved) speed between two scans; the likelihood field then picks the
particles that fit. The fused pose is the estimate itself (the correction is renewed against
the frozen odometry pose). When the encoders return, ``Localiser.set_lidar_only`` re-anchors
the correction on the odometry pose of that moment, so a jump of the counters does not move the
robot on the map.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from behaviours.nav.localisation.motion_model import compose, inverse, wrap

FloatArray = npt.NDArray[np.float64]

SIGMA_M = 0.025
"""Position noise per scan (a 10 Hz LiDAR at a halved 0.1 m/s: 1 cm between scans)."""
SIGMA_RAD = 0.035
"""Heading noise per scan (a halved in-place turn: ~0.03 rad between scans)."""
VELOCITY_GAIN = 0.7
"""Share of the last step's motion carried into the next prediction (damped: no runaway)."""
CATCH_UP_SCANS = 3
CATCH_UP_FACTOR = 3.0
"""The first scans after the switch spread the particles wider: the failure is seen only after
``encoder_freeze_s`` of frozen ticks, and the robot drove on meanwhile (~10 cm at 0.2 m/s)."""


class LidarOnlyMotion:
    """The motion step while odometry is not trusted: damped constant velocity plus noise."""

    def __init__(self) -> None:
        self.step: FloatArray = np.zeros(3)  # the last estimate-to-estimate motion, robot frame
        self._last_estimate: FloatArray | None = None
        self.updates = 0

    def predict(self, poses: FloatArray, rng: np.random.Generator) -> FloatArray:
        n = poses.shape[0]
        moved = compose(poses, self.step * VELOCITY_GAIN)
        noise = rng.standard_normal((n, 3))
        wide = CATCH_UP_FACTOR if self.updates < CATCH_UP_SCANS else 1.0
        moved[:, 0] += SIGMA_M * wide * noise[:, 0]
        moved[:, 1] += SIGMA_M * wide * noise[:, 1]
        moved[:, 2] = wrap(moved[:, 2] + SIGMA_RAD * wide * noise[:, 2])
        self.updates += 1
        return moved

    def estimated(self, estimate: FloatArray) -> None:
        """The filter's new estimate: the step it made becomes the next prediction's."""
        if self._last_estimate is not None:
            self.step = compose(inverse(self._last_estimate), estimate)
        self._last_estimate = np.array(estimate, dtype=np.float64)
