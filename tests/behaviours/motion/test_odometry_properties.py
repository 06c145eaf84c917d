"""Seed property 16: odometry's pose change matches the wheel geometry."""

from __future__ import annotations

import math

from hypothesis import given, settings
from hypothesis import strategies as st

from behaviours.motion.odometry import Odometry
from hal.readings import EncoderReading

WHEEL_BASE_M = 0.25  # the seed's WHEEL_BASE, WHEEL_RADIUS, ENCODER_TICKS_PER_REVOLUTION
WHEEL_RADIUS_M = 0.05
TICKS_PER_REV = 360


class TestOdometryProperties:
    # Feature: relaybot-autonomous-delivery, Property 16: For any pair of consecutive wheel
    # encoder readings, the calculated position change should match the expected delta based
    # on wheel geometry (within 5% error).
    @given(st.tuples(st.integers(-10_000, 10_000), st.integers(-10_000, 10_000)),
           # Consecutive readings: the board reports at 20 Hz or more, and 100 ticks (8.7 cm)
           # in 50 ms is 1.7 m/s, past any of these robots. Odometry integrates a step along
           # its mid heading (the exact direction) with the wheels' mean travel for length,
           # which is the chord within 2 % up to 0.7 rad a step.
           st.tuples(st.integers(-100, 100), st.integers(-100, 100)),
           st.floats(-math.pi, math.pi))
    @settings(max_examples=200)
    def test_property_16_a_step_moves_as_the_wheels_say(
            self, first: tuple[int, int], delta: tuple[int, int], heading: float) -> None:
        """The chord and turn of one step are the exact arc's (constant curvature)."""
        odo = Odometry(WHEEL_BASE_M, WHEEL_RADIUS_M, TICKS_PER_REV)
        odo.reset(1.0, -2.0, heading)
        odo.update(EncoderReading(first[0], first[1], 0.0))
        before = odo.pose()
        odo.update(EncoderReading(first[0] + delta[0], first[1] + delta[1], 0.05))
        after = odo.pose()
        m_per_tick = 2 * math.pi * WHEEL_RADIUS_M / TICKS_PER_REV
        left, right = delta[0] * m_per_tick, delta[1] * m_per_tick
        dtheta = (right - left) / WHEEL_BASE_M
        d = (left + right) / 2
        # The exact arc: chord = 2 R sin(dtheta / 2), R = d / dtheta.
        chord = d if abs(dtheta) < 1e-9 else 2 * d / dtheta * math.sin(dtheta / 2)
        moved = math.hypot(after.x_m - before.x_m, after.y_m - before.y_m)
        assert abs(moved - abs(chord)) <= 0.05 * abs(chord) + 1e-9
        turned = math.remainder(after.theta_rad - before.theta_rad, 2 * math.tau)
        assert abs(math.remainder(turned - dtheta, math.tau)) <= 0.05 * abs(dtheta) + 1e-9
