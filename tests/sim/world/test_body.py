"""The simulated body: motors answer PWM, encoders count, walls stop it, battery drains."""

from __future__ import annotations

import math
import random
import statistics

from sim.world.body import BodyParams, DiffDriveBody
from sim.world.floor_plan import World
from sim.world.geometry import Pose


def _world() -> World:
    return World.from_table({"width_m": 4, "height_m": 4})


def _run(body: DiffDriveBody, seconds: float, dt: float = 0.01) -> None:
    for _ in range(round(seconds / dt)):
        body.step(dt)


class TestDiffDriveBody:
    def test_equal_pwm_drives_straight_at_the_calibrated_speed(self) -> None:
        """PWM 255 on both wheels reaches max_wheel_speed_mps, heading unchanged."""
        body = DiffDriveBody(_world(), Pose(1, 2, 0), BodyParams(slip_std=0))
        body.apply_pwm(255, 255, True, True)
        _run(body, 1.0)
        assert body.pose.x_m > 1.5
        assert abs(body.pose.y_m - 2) < 1e-9
        assert math.isclose(body.wheel_mps[0], 0.6, rel_tol=1e-3)

    def test_pwm_inside_the_deadband_does_not_move(self) -> None:
        body = DiffDriveBody(_world(), Pose(1, 1, 0))
        body.apply_pwm(15, 15, True, True)
        _run(body, 1.0)
        assert body.pose == Pose(1, 1, 0)
        assert body.encoder_ticks() == (0, 0)

    def test_encoders_count_wheel_turns(self) -> None:
        """One metre of wheel travel is 1 / (2 pi r) turns of ticks_per_rev ticks."""
        body = DiffDriveBody(_world(), Pose(0.5, 2, 0), BodyParams(slip_std=0))
        body.apply_pwm(255, 255, True, True)
        _run(body, 2.0)
        left, right = body.encoder_ticks()
        expected = body.distance_m / (2 * math.pi * 0.035) * 360
        assert abs(left - expected) <= 1 and abs(right - expected) <= 1

    def test_opposite_wheels_turn_in_place(self) -> None:
        body = DiffDriveBody(_world(), Pose(2, 2, 0), BodyParams(slip_std=0))
        body.apply_pwm(100, 100, False, True)
        _run(body, 0.5)
        assert body.pose.distance_to(2, 2) < 1e-9
        assert body.pose.heading_rad > 0.1

    def test_a_wall_stops_the_body_and_is_recorded_once(self) -> None:
        body = DiffDriveBody(_world(), Pose(3.5, 2, 0))
        body.apply_pwm(200, 200, True, True)
        _run(body, 3.0)
        assert body.pose.x_m <= 4 - 0.18 + 1e-6
        assert len(body.collisions) == 1

    def test_slip_noise_depends_on_the_seed(self) -> None:
        poses = []
        for seed in (1, 2):
            body = DiffDriveBody(_world(), Pose(0.5, 2, 0), rng=random.Random(seed))
            body.apply_pwm(120, 120, True, True)
            _run(body, 2.0)
            poses.append(body.pose)
        assert poses[0] != poses[1]

    def test_battery_drains_with_motion_and_charges_on_the_dock(self) -> None:
        world = World.from_table({"width_m": 4, "height_m": 4,
                                  "dock": {"x_m": 1.0, "y_m": 1.0, "heading_deg": 0}})
        moving = DiffDriveBody(world, Pose(2, 2, 0))
        moving.apply_pwm(255, 255, True, False)
        _run(moving, 60)
        assert moving.charge_pct < 100
        assert world.dock is not None
        docked = DiffDriveBody(world, world.dock.docked_pose(0.18), charge_pct=50)
        _run(docked, 60)
        assert docked.charge_pct > 50
        assert docked.battery()[2] is True

    def test_front_range_sees_a_wall_and_a_person(self) -> None:
        world = World.from_table({"width_m": 4, "height_m": 4,
                                  "people": [{"x_m": 2.0, "y_m": 1.0}]})
        body = DiffDriveBody(world, Pose(3.0, 2.0, 0), BodyParams(range_noise_cm=0))
        assert math.isclose(body.front_range_cm(), (4 - 3 - 0.18) * 100, abs_tol=0.01)
        facing_person = DiffDriveBody(world, Pose(1.0, 1.0, 0), BodyParams(range_noise_cm=0))
        assert math.isclose(facing_person.front_range_cm(), (1.0 - 0.2 - 0.18) * 100,
                            abs_tol=0.01)

    def test_slip_noise_does_not_depend_on_how_often_the_body_is_touched(self) -> None:
        """Synced every 37 ms with range reads between, or only at PWM changes: same path."""

        class Clock:
            t_s = 0.0

            def __call__(self) -> float:
                return self.t_s

        clocks = (Clock(), Clock())
        bodies = [DiffDriveBody(_world(), Pose(1, 1, 0.3), rng=random.Random(4), clock=clock)
                  for clock in clocks]
        for i in range(200):
            for n, (body, clock) in enumerate(zip(bodies, clocks, strict=True)):
                clock.t_s += 0.037
                if i % 20 == 0:
                    body.apply_pwm(90 + i % 7, 100, True, True)
                if n == 0:
                    if i % 3 == 0:
                        body.front_range_cm()  # draws from rng, not from the slip noise
                    body.sync()
        assert bodies[0].pose == bodies[1].pose
        assert bodies[0].encoder_ticks() == bodies[1].encoder_ticks()

    def test_slip_factors_have_the_configured_spread(self) -> None:
        """Each wheel's ground travel per step is off by N(0, slip_std), as rng.gauss drew."""
        slips = []
        for seed in range(4):
            body = DiffDriveBody(_world(), Pose(0.5, 2, 0), BodyParams(slip_std=0.02),
                                 rng=random.Random(seed))
            body.apply_pwm(150, 150, True, True)
            _run(body, 0.5)
            slips += body._slips  # the drawn block itself
        assert abs(statistics.fmean(slips) - 1) < 0.002
        assert abs(statistics.stdev(slips) - 0.02) < 0.001
