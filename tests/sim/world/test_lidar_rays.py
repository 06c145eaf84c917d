"""The simulated LiDAR's ray caster: walls, legs, grazing dropouts, the angle culling."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from sim.world.body import DiffDriveBody
from sim.world.floor_plan import Person, World
from sim.world.geometry import Pose, segments_array
from sim.world.lidar_rays import LidarRays, cast_circles, cast_segments
from sim.world.walkers import LEG_RADIUS_M, Walk


def _room(people: list[Person] | None = None) -> World:
    walls = segments_array([(0, 0, 4, 0), (4, 0, 4, 4), (4, 4, 0, 4), (0, 4, 0, 0)])
    return World(4.0, 4.0, walls, people=people or [])


def _rays(world: World, x: float = 1.0, y: float = 2.0, heading: float = 0.0,
          t_s: float = 0.0, **kw: float) -> LidarRays:
    body = DiffDriveBody(world, Pose(x, y, heading))
    return LidarRays(world, body, clock=lambda: t_s, **kw)


class TestWalls:
    def test_square_room_ranges(self) -> None:
        """Beams along the axes hit the walls at their distance."""
        rays = _rays(_room())
        got = rays(np.array([0.0, math.pi / 2, math.pi, -math.pi / 2]))
        assert np.allclose(got, [3.0, 2.0, 1.0, 2.0])

    def test_heading_and_mount_yaw_turn_the_beams(self) -> None:
        """Sensor angles are relative to the body's heading plus the mount's yaw."""
        rays = _rays(_room(), heading=math.pi / 2, mount_yaw_rad=math.pi / 2)
        assert math.isclose(float(rays(np.array([0.0]))[0]), 1.0)  # facing -x

    def test_grazing_beams_give_no_return(self) -> None:
        """A beam more than grazing_deg off the wall's normal is dropped; a steep one is not."""
        seg = segments_array([(-10, 1, 10, 1)])
        normal = np.array([[0.0, 1.0]])
        angles = np.radians([90.0, 20.0, 5.0])
        got = cast_segments(seg, normal, 0.0, 0.0, angles, math.cos(math.radians(80)))
        assert math.isclose(got[0], 1.0)
        assert math.isclose(got[1], 1 / math.sin(math.radians(20)))
        assert math.isinf(got[2])

    @settings(max_examples=60, deadline=None)
    @given(st.floats(0.3, 3.7), st.floats(0.3, 3.7), st.floats(-math.pi, math.pi))
    def test_culling_changes_no_range(self, x: float, y: float, mid: float) -> None:
        """Ranges of a narrow arc equal those of the same beams cast one by one (no cull)."""
        world = _room()
        world.walls = np.concatenate([world.walls, segments_array(
            [(1.5, 1.5, 2.5, 1.5), (2.5, 1.5, 2.5, 2.5), (0.2, 3.0, 0.9, 3.6)])])
        rays = _rays(world, x, y)
        angles = mid + np.radians(np.arange(12) * 0.8)
        together = rays(angles)
        alone = np.array([rays(np.array([a]))[0] for a in angles])
        assert np.allclose(together, alone, equal_nan=True)


class TestPeople:
    def test_two_legs_are_seen_as_two_arcs(self) -> None:
        """A person facing the sensor shows two legs, 22 cm apart across the beams."""
        person = Person("p", 3.0, 2.0, heading_rad=math.pi)
        rays = _rays(_room([person]), 1.0, 2.0)
        angles = np.radians(np.linspace(-10, 10, 401))
        got = rays(angles)
        hit = got < 2.5
        assert hit.any()
        runs = np.count_nonzero(np.diff(hit.astype(int)) == 1)
        assert runs == 2
        assert float(got.min()) >= 2.0 - LEG_RADIUS_M - 0.11 - 1e-6

    def test_a_body_circle_when_legs_are_off(self) -> None:
        """legs = false: one circle of the person's radius."""
        person = Person("p", 3.0, 2.0, legs=False)
        got = _rays(_room([person]))(np.array([0.0]))
        assert math.isclose(float(got[0]), 2.0 - person.radius_m)

    def test_a_walker_is_where_its_walk_puts_it(self) -> None:
        """Walking at 1 m/s from (3, 0.5) to (3, 3.5): after 1.5 s it blocks the beam at y=2."""
        person = Person("p", 3.0, 0.5, legs=False)
        person.walk = Walk(((3.0, 0.5), (3.0, 3.5)), 1.0, 0.0)
        world = _room([person])
        assert math.isclose(float(_rays(world, t_s=1.5)(np.array([0.0]))[0]), 1.8)
        assert math.isclose(float(_rays(world, t_s=3.5)(np.array([0.0]))[0]), 3.0)

    def test_circles_behind_are_not_hit(self) -> None:
        """A circle behind the sensor gives no return."""
        got = cast_circles(np.array([[-1.0, 0.0, 0.2]]), 0.0, 0.0, np.array([0.0]))
        assert math.isinf(got[0])


class TestWalk:
    @settings(max_examples=50, deadline=None)
    @given(st.floats(0.0, 100.0))
    def test_a_loop_stays_on_its_path(self, t_s: float) -> None:
        """A looping walk is always on the square it walks (never off the polyline)."""
        walk = Walk(((0, 0), (1, 0), (1, 1), (0, 1)), 0.7, 0.0, loop=True)
        x, y, _h, moving = walk.at(t_s)
        assert moving
        on_edge = min(abs(x), abs(x - 1), abs(y), abs(y - 1))
        assert on_edge < 1e-9
