"""The vacuum's body: bumpers, the right-side wall sensor, the dust bin and the battery."""

from __future__ import annotations

import math

import pytest

from sim.world import touch
from sim.world.body import BodyParams, DiffDriveBody
from sim.world.floor_plan import World
from sim.world.geometry import Pose

RADIUS_M = BodyParams().radius_m


def _room(**extra: object) -> World:
    return World.from_table({"width_m": 4, "height_m": 4, **extra})


class TestBumpers:
    def test_a_wall_straight_ahead_presses_both(self) -> None:
        assert touch.bumpers(_room(), Pose(4 - RADIUS_M - 0.002, 2, 0), RADIUS_M) == (True, True)

    def test_a_wall_to_the_front_left_presses_the_left_one(self) -> None:
        pose = Pose(2, 4 - RADIUS_M - 0.002, math.radians(45))
        assert touch.bumpers(_room(), pose, RADIUS_M) == (True, False)

    def test_a_wall_to_the_front_right_presses_the_right_one(self) -> None:
        pose = Pose(2, 4 - RADIUS_M - 0.002, math.radians(135))
        assert touch.bumpers(_room(), pose, RADIUS_M) == (False, True)

    def test_a_wall_behind_presses_nothing(self) -> None:
        assert touch.bumpers(_room(), Pose(RADIUS_M + 0.002, 2, 0), RADIUS_M) == (False, False)

    def test_a_person_presses_it(self) -> None:
        world = _room(people=[{"x_m": 2.5, "y_m": 2.0}])
        pose = Pose(2.5 - 0.2 - RADIUS_M - 0.002, 2.0, 0)
        assert touch.bumpers(world, pose, RADIUS_M) == (True, True)
        world.people[0].present = False
        assert touch.bumpers(world, pose, RADIUS_M) == (False, False)

    def test_driving_into_a_wall_leaves_it_pressed(self) -> None:
        body = DiffDriveBody(_room(), Pose(3.0, 2.0, 0), BodyParams(slip_std=0))
        body.apply_pwm(200, 200, True, True)
        for _ in range(300):
            body.step(0.01)
        assert body.bumpers() == (True, True)


class TestWallSensor:
    def test_a_wall_on_the_right_reads_its_distance(self) -> None:
        """Heading east 0.25 m north of the south wall: the rim is 7 cm from it."""
        pose = Pose(2.0, 0.25, 0)
        assert touch.wall_cm(_room(), pose, RADIUS_M) == pytest.approx(7.0, abs=0.01)

    def test_nothing_in_range_reads_the_maximum(self) -> None:
        assert touch.wall_cm(_room(), Pose(2, 2, 0), RADIUS_M) == touch.WALL_MAX_CM

    def test_a_wall_on_the_left_is_not_seen(self) -> None:
        assert touch.wall_cm(_room(), Pose(2.0, 3.75, 0), RADIUS_M) == touch.WALL_MAX_CM


class TestDustBin:
    def _vacuum(self, world: World, pose: Pose) -> DiffDriveBody:
        return DiffDriveBody(world, pose, BodyParams(slip_std=0, cleans=True))

    def test_it_fills_while_cleaning(self) -> None:
        body = self._vacuum(_room(), Pose(0.5, 2, 0))
        body.apply_pwm(200, 200, True, True)
        for _ in range(400):
            body.step(0.01)
        assert body.bin_pct == pytest.approx(body.distance_m * 0.5)
        assert body.bin_pct > 0

    def test_a_robot_that_does_not_clean_collects_nothing(self) -> None:
        body = DiffDriveBody(_room(), Pose(0.5, 2, 0), BodyParams(slip_std=0))
        body.apply_pwm(200, 200, True, True)
        for _ in range(400):
            body.step(0.01)
        assert body.bin_pct == 0

    def test_it_empties_only_with_suction_on_and_the_door_open(self) -> None:
        world = _room(dock={"x_m": 0.14, "y_m": 2, "heading_deg": 0})
        assert world.dock is not None
        body = self._vacuum(world, world.dock.docked_pose(RADIUS_M))
        body.bin_pct = 80.0
        for suction, door_deg in ((True, 0), (False, 90)):
            world.dock.suction = suction
            body.servo(door_deg)
            for _ in range(100):
                body.step(0.01)
            assert body.bin_pct == 80.0
        world.dock.suction = True
        for _ in range(200):
            body.step(0.01)
        assert body.bin_pct == pytest.approx(80.0 - 2.0 * BodyParams().evac_pct_per_s)


class TestBattery:
    def test_cleaning_drains_faster_than_driving(self) -> None:
        charges = []
        for cleans in (False, True):
            body = DiffDriveBody(_room(), Pose(0.5, 2, 0), BodyParams(cleans=cleans))
            body.apply_pwm(120, 120, True, False)
            for _ in range(1000):
                body.step(0.01)
            charges.append(body.charge_pct)
        assert charges[1] < charges[0] < 100

    def test_it_charges_on_the_pads_but_not_with_a_contacts_fault(self) -> None:
        world = _room(dock={"x_m": 0.14, "y_m": 2, "heading_deg": 0})
        assert world.dock is not None
        body = DiffDriveBody(world, world.dock.docked_pose(RADIUS_M), charge_pct=50)
        world.dock.contacts_fault = True
        for _ in range(1000):
            body.step(0.01)
        assert body.charge_pct < 50
        world.dock.contacts_fault = False
        for _ in range(1000):
            body.step(0.01)
        assert body.charge_pct > 50
