"""AMCL's odometry motion model and the pose algebra it rests on."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from behaviours.nav.localisation.motion_model import (
    compose,
    inverse,
    relative,
    sample_odometry_motion,
)

coord = st.floats(-20, 20, allow_nan=False)
heading = st.floats(-math.pi, math.pi, allow_nan=False, exclude_max=True)
pose = st.tuples(coord, coord, heading)


def _close(a: np.ndarray, b: np.ndarray) -> bool:
    return bool(np.allclose(a[:2], b[:2], atol=1e-9)
                and abs(math.remainder(a[2] - b[2], 2 * math.pi)) < 1e-9)


class TestPoseAlgebra:
    @given(pose, pose)
    def test_relative_undoes_compose(self, a: tuple[float, float, float],
                                     b: tuple[float, float, float]) -> None:
        """relative(a, compose(a, b)) is b again."""
        assert _close(relative(a, compose(a, b)), np.array(b))

    @given(pose)
    def test_inverse_composes_to_identity(self, a: tuple[float, float, float]) -> None:
        """a composed with its inverse is the identity pose."""
        assert _close(compose(a, inverse(a)), np.zeros(3))


class TestOdometryMotionModel:
    def test_without_noise_each_particle_moves_by_the_step_in_its_own_frame(self) -> None:
        """alphas 0: a particle at p ends at p (+) (odometry step seen from the old pose)."""
        rng = np.random.default_rng(1)
        particles = np.array([[0.0, 0.0, 0.0], [1.0, 2.0, math.pi / 2], [-3, 1, -2.0]])
        start, end = (0.5, 0.5, 0.3), (1.2, 0.9, 0.8)
        moved = sample_odometry_motion(particles, start, end, (0, 0, 0, 0), rng)
        step = relative(start, end)
        for p, m in zip(particles, moved, strict=True):
            assert _close(m, compose(p, step))

    def test_straight_drive_spreads_as_the_alphas_say(self) -> None:
        """1 m straight: trans std = sqrt(alpha3), heading std = sqrt(2 alpha2) (rot1 + rot2)."""
        rng = np.random.default_rng(2)
        alphas = (0.01, 0.004, 0.02, 0.03)
        n = 40000
        moved = sample_odometry_motion(np.zeros((n, 3)), (0, 0, 0), (1, 0, 0), alphas, rng)
        trans = np.hypot(moved[:, 0], moved[:, 1])
        assert abs(trans.mean() - 1.0) < 0.005
        assert abs(trans.std() - math.sqrt(alphas[2])) / math.sqrt(alphas[2]) < 0.05
        assert abs(moved[:, 2].std() - math.sqrt(2 * alphas[1])) / math.sqrt(2 * alphas[1]) < 0.05

    def test_turn_on_the_spot_spreads_heading_by_alpha1(self) -> None:
        """A 90 degree turn in place: heading std = sqrt(alpha1) * 90 degrees, no bearing."""
        rng = np.random.default_rng(3)
        alphas = (0.02, 0.0, 0.0, 0.0)
        n = 40000
        turn = math.pi / 2
        moved = sample_odometry_motion(np.zeros((n, 3)), (0, 0, 0), (0, 0, turn), alphas, rng)
        assert abs(moved[:, 2].mean() - turn) < 0.005
        want = math.sqrt(alphas[0]) * turn
        assert abs(moved[:, 2].std() - want) / want < 0.05
        assert np.allclose(moved[:, :2], 0.0)

    def test_driving_backwards_is_no_noisier_than_forwards(self) -> None:
        """AMCL: a bearing of pi (reversing) counts as no turn in the rotation noise."""
        alphas = (0.05, 0.0, 0.01, 0.0)
        fwd = sample_odometry_motion(np.zeros((20000, 3)), (0, 0, 0), (0.5, 0, 0), alphas,
                                     np.random.default_rng(4))
        back = sample_odometry_motion(np.zeros((20000, 3)), (0, 0, 0), (-0.5, 0, 0), alphas,
                                      np.random.default_rng(4))
        assert np.std(back[:, 2]) < 1.2 * np.std(fwd[:, 2]) + 1e-3
