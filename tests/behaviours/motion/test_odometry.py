"""Wheel odometry from cumulative encoder ticks."""

from __future__ import annotations

import asyncio
import math
from collections.abc import Callable

import pytest
from hypothesis import given
from hypothesis import strategies as st

from behaviours.motion.odometry import Odometry
from behaviours.motion.waypoint_drive import OdometryTracker
from hal.latest import LatestValue
from hal.readings import EncoderReading
from sim import vclock

TICKS_PER_M = 360 / (2 * math.pi * 0.035)


def _odo() -> Odometry:
    return Odometry(0.30, 0.035, 360)


class TestOdometry:
    def test_first_reading_only_sets_the_reference(self) -> None:
        odo = _odo()
        odo.update(EncoderReading(5000, 5000, 0.0))
        assert odo.pose().x_m == 0.0

    def test_equal_ticks_move_straight(self) -> None:
        odo = _odo()
        odo.update(EncoderReading(0, 0, 0.0))
        for i in range(1, 11):
            odo.update(EncoderReading(round(i * 0.1 * TICKS_PER_M), round(i * 0.1 * TICKS_PER_M),
                                      i * 0.1))
        assert odo.pose().x_m == pytest.approx(1.0, abs=0.002)
        assert odo.pose().y_m == pytest.approx(0.0)

    def test_opposite_ticks_turn_in_place(self) -> None:
        """A quarter turn: each wheel travels pi/2 * b/2."""
        odo = _odo()
        odo.update(EncoderReading(0, 0, 0.0))
        ticks = round(math.pi / 2 * 0.15 * TICKS_PER_M)
        odo.update(EncoderReading(-ticks, ticks, 1.0))
        assert odo.pose().theta_rad == pytest.approx(math.pi / 2, abs=0.01)
        assert math.hypot(odo.pose().x_m, odo.pose().y_m) < 1e-9

    def test_a_board_reset_rebases_instead_of_jumping(self) -> None:
        odo = _odo()
        odo.update(EncoderReading(0, 0, 0.0))
        odo.update(EncoderReading(9000, 9000, 1.0))
        assert odo.pose().x_m == 0.0
        assert odo.rebases == 1

    @given(st.lists(st.tuples(st.integers(-50, 50), st.integers(-50, 50)), max_size=60))
    def test_driving_back_along_the_same_ticks_returns_home(
        self, steps: list[tuple[int, int]]
    ) -> None:
        """Replaying the same tick deltas backwards, in reverse order, undoes the motion."""
        odo = _odo()
        left = right = 0
        odo.update(EncoderReading(0, 0, 0.0))
        for dl, dr in steps:
            left, right = left + dl, right + dr
            odo.update(EncoderReading(left, right, 0.0))
        for dl, dr in reversed(steps):
            left, right = left - dl, right - dr
            odo.update(EncoderReading(left, right, 0.0))
        assert math.hypot(odo.pose().x_m, odo.pose().y_m) < 1e-6


class TestOdometryTracker:
    def test_listenable_encoders_update_odometry_as_each_reading_arrives(self) -> None:
        """With encoders that call back, the odometry moves on publish, before any task runs."""

        class Feed:
            def __init__(self) -> None:
                self.value: LatestValue[EncoderReading] = LatestValue()

            def latest(self) -> EncoderReading | None:
                return self.value.latest()

            async def next_reading(self) -> EncoderReading:
                return await self.value.next()

            def listen(self, callback: Callable[[EncoderReading], object]) -> Callable[[], None]:
                return self.value.listen(callback)

        async def main() -> tuple[float, float]:
            feed, odo = Feed(), _odo()
            feed.value.publish(EncoderReading(0, 0, 0.0))
            task = asyncio.create_task(OdometryTracker(feed, odo).run())
            await asyncio.sleep(0)
            ticks = round(0.5 * TICKS_PER_M)
            feed.value.publish(EncoderReading(ticks, ticks, 0.05))
            moved = odo.pose().x_m
            task.cancel()
            await asyncio.gather(task, return_exceptions=True)
            feed.value.publish(EncoderReading(2 * ticks, 2 * ticks, 0.1))
            return moved, odo.pose().x_m

        moved, after_cancel = vclock.run(main())
        assert moved == pytest.approx(0.5, abs=0.002)
        assert after_cancel == moved  # cancelled: no longer listening
