"""The simulated dock: beams as sectors, occlusion, its body as an obstacle, the contacts."""

from __future__ import annotations

import math
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from sim.world.body import BodyParams, DiffDriveBody
from sim.world.dock import DEFAULT_BEAMS, Dock
from sim.world.floor_plan import World, WorldError
from sim.world.geometry import Pose, segments_array

RADIUS_M = BodyParams().radius_m


def _world(**extra: Any) -> World:
    """A 6 x 4 m room, the dock on the west wall's middle looking east (+x)."""
    return World.from_table({"width_m": 6, "height_m": 4,
                             "dock": {"x_m": 0.14, "y_m": 2.0, "heading_deg": 0}, **extra})


def _dock(world: World) -> Dock:
    assert world.dock is not None
    return world.dock


def _reaching(world: World, x_m: float, y_m: float) -> set[str]:
    dock = _dock(world)
    people = [(p.x_m, p.y_m, p.radius_m) for p in world.people if p.present]
    return {b.name for slot in range(dock.slots)
            for b in dock.beams_reaching(slot, x_m, y_m, world.walls, people)}


class TestBeams:
    def test_on_the_axis_close_in_every_front_beam_reaches(self) -> None:
        """0.5 m out on the axis: both front beams, the centre and the force field."""
        assert _reaching(_world(), 0.64, 2.0) == {"front_left", "front_right", "centre",
                                                  "force_field"}

    def test_on_the_axis_far_out_only_the_front_pair_reaches(self) -> None:
        """2 m out on the axis: the two narrow front beams overlap there, nothing else."""
        assert _reaching(_world(), 2.14, 2.0) == {"front_left", "front_right"}

    def test_off_to_the_robots_left_only_far_left_reaches(self) -> None:
        """A robot facing the dock from 45 deg to its left (the dock's right, -y) at 1.5 m
        is in far_left alone."""
        x, y = 0.14 + 1.5 * math.cos(math.radians(-45)), 2.0 + 1.5 * math.sin(math.radians(-45))
        assert _reaching(_world(), x, y) == {"far_left"}

    def test_behind_the_dock_nothing_reaches_beyond_the_force_field(self) -> None:
        world = World.from_table({"width_m": 6, "height_m": 4,
                                  "dock": {"x_m": 3.0, "y_m": 2.0, "heading_deg": 0}})
        assert _reaching(world, 2.0, 2.0) == set()
        assert _reaching(world, 2.6, 2.0) == {"force_field"}

    def test_a_wall_between_blocks_every_beam(self) -> None:
        world = _world(walls=[{"x1": 1.0, "y1": 1.0, "x2": 1.0, "y2": 3.0}])
        assert _reaching(world, 1.5, 2.0) == set()

    def test_a_person_in_the_beam_blocks_it(self) -> None:
        world = _world(people=[{"x_m": 1.2, "y_m": 2.0}])
        assert _reaching(world, 2.14, 2.0) == set()

    def test_beams_off_reach_nowhere(self) -> None:
        world = _world()
        _dock(world).emitting = False
        assert _reaching(world, 0.64, 2.0) == set()

    @given(st.floats(0.2, 5.8), st.floats(0.2, 3.8))
    def test_a_beam_reaches_only_inside_its_range(self, x_m: float, y_m: float) -> None:
        """Whatever reaches a point lies within that beam's range of its apex."""
        world = _world()
        dock = _dock(world)
        for name in _reaching(world, x_m, y_m):
            ax, ay = dock.beam(name).apex(dock.pose)
            assert math.hypot(x_m - ax, y_m - ay) <= dock.beam(name).range_m + 1e-9

    def test_slot_zero_is_the_oi_home_base(self) -> None:
        """Force field and the two buoys share a slot: together they OR into OI codes."""
        slot0 = {b.name: b.code for b in DEFAULT_BEAMS if b.slot == 0}
        assert slot0 == {"force_field": 161, "front_left": 168, "front_right": 164}
        assert len({b.code for b in DEFAULT_BEAMS}) == len(DEFAULT_BEAMS)


class TestDockTable:
    def test_a_beam_can_be_changed_by_name(self) -> None:
        world = _world(dock={"x_m": 0.14, "y_m": 2, "beams": [{"name": "centre",
                                                                "range_m": 1.5}]})
        assert _dock(world).beam("centre").range_m == 1.5
        assert _dock(world).beam("centre").code == 176

    def test_unknown_key_is_named(self) -> None:
        with pytest.raises(WorldError, match=r"world.dock.colour: unknown key"):
            _world(dock={"x_m": 0.14, "y_m": 2, "colour": "red"})

    def test_a_code_given_twice_is_named(self) -> None:
        with pytest.raises(WorldError, match=r"world.dock.beams\[0\].code: 161 is already"):
            _world(dock={"x_m": 0.14, "y_m": 2, "beams": [{"name": "centre", "code": 161}]})

    def test_a_new_beam_needs_its_fields(self) -> None:
        with pytest.raises(WorldError, match=r"world.dock.beams\[0\].code: required"):
            _world(dock={"x_m": 0.14, "y_m": 2, "beams": [{"name": "wide"}]})

    def test_a_slot_too_short_for_a_frame_is_refused(self) -> None:
        with pytest.raises(WorldError, match=r"world.dock.slot_s"):
            _world(dock={"x_m": 0.14, "y_m": 2, "slot_s": 0.02})


class TestContacts:
    def test_docked_pose_touches_the_pads_at_the_station_voltage(self) -> None:
        dock = _dock(_world())
        pose = dock.docked_pose(RADIUS_M)
        assert dock.touching(pose, RADIUS_M)
        assert 14_000 <= dock.voltage_mv(pose, RADIUS_M) <= 19_000

    def test_off_the_pads_the_voltage_is_zero(self) -> None:
        dock = _dock(_world())
        docked = dock.docked_pose(RADIUS_M)
        for pose in (Pose(docked.x_m + 0.03, docked.y_m, docked.heading_rad),
                     Pose(docked.x_m, docked.y_m + 0.04, docked.heading_rad),
                     Pose(docked.x_m, docked.y_m, docked.heading_rad + math.radians(20))):
            assert dock.voltage_mv(pose, RADIUS_M) == 0

    def test_a_contacts_fault_gives_an_abnormal_voltage_and_no_charge(self) -> None:
        dock = _dock(_world())
        dock.contacts_fault = True
        pose = dock.docked_pose(RADIUS_M)
        assert not 14_000 <= dock.voltage_mv(pose, RADIUS_M) <= 19_000
        assert not dock.charges(pose, RADIUS_M)


class TestDockAsObstacle:
    def test_driving_straight_in_ends_on_the_pads_without_a_bump(self) -> None:
        """Nose first along the axis: the pads stop the robot, charging, no collision."""
        world = _world()
        body = DiffDriveBody(world, Pose(1.2, 2.0, math.pi), BodyParams(slip_std=0))
        body.apply_pwm(80, 80, True, True)
        for _ in range(800):
            body.step(0.01)
        assert body.collisions == []
        assert body.on_dock
        assert 14_000 <= body.contact_mv() <= 19_000
        assert body.bumpers() == (False, False)

    def test_driving_into_its_side_is_a_bump(self) -> None:
        world = World.from_table({"width_m": 6, "height_m": 4,
                                  "dock": {"x_m": 3.0, "y_m": 2.0, "heading_deg": 0}})
        body = DiffDriveBody(world, Pose(2.93, 3.0, -math.pi / 2), BodyParams(slip_std=0))
        body.apply_pwm(80, 80, True, True)
        for _ in range(1000):
            body.step(0.01)
        assert len(body.collisions) == 1
        assert body.pose.y_m > 2.0 + 0.17 + RADIUS_M - 0.01
        assert body.bumpers() == (True, True)

    def test_a_world_without_a_dock_has_the_walls_alone(self) -> None:
        world = World.from_table({"width_m": 6, "height_m": 4})
        body = DiffDriveBody(world, Pose(3, 2, 0))
        assert body.contact_mv() == 0
        assert world.walls.shape == segments_array([(0, 0, 1, 1)] * 4).shape
