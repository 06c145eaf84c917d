"""People in the scan: unexplained clusters, sized by width and range, tracked across scans."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from nav_room import Segment, grid, scan_at

from behaviours.nav.localisation.config import PeopleConfig
from behaviours.nav.localisation.likelihood_field import DistanceGrid
from behaviours.nav.localisation.people import PeopleTracker, detect, min_points

STEP_RAD = math.radians(0.8)  # the LD19: 4500 points/s at 10 turns/s


def circle(x: float, y: float, r: float, sides: int = 16) -> list[Segment]:
    pts = [(x + r * math.cos(a), y + r * math.sin(a))
           for a in np.linspace(0, 2 * math.pi, sides, endpoint=False)]
    return [(*pts[i], *pts[(i + 1) % sides]) for i in range(sides)]


def legs(x: float, y: float, facing_rad: float = 0.0, apart_m: float = 0.24) -> list[Segment]:
    """Two legs (0.12 m across) side by side, ``apart_m`` between centres."""
    dx, dy = -math.sin(facing_rad) * apart_m / 2, math.cos(facing_rad) * apart_m / 2
    return [*circle(x + dx, y + dy, 0.06), *circle(x - dx, y - dy, 0.06)]


def to_robot(pose: tuple[float, float, float], x: float, y: float) -> tuple[float, float]:
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return c * (x - pose[0]) + s * (y - pose[1]), -s * (x - pose[0]) + c * (y - pose[1])


@pytest.fixture(scope="module")
def room() -> DistanceGrid:
    return grid()


class TestMinPoints:
    def test_close_by_the_seeds_ten_points_far_out_what_the_width_spans(self) -> None:
        """0.4 m at 1 m: the seed's 10; at 3 m: half the 9.5 points it spans; never < 3."""
        cfg = PeopleConfig()
        assert min_points(0.4, 1.0, STEP_RAD, cfg) == 10
        assert min_points(0.4, 3.0, STEP_RAD, cfg) == 5
        assert min_points(0.1, 5.0, STEP_RAD, cfg) == 3


class TestDetect:
    def test_an_empty_room_has_nobody(self, room: DistanceGrid) -> None:
        """Walls and furniture on the map explain every point: no people."""
        pose = (3.0, 3.0, 0.3)
        scan = scan_at(pose, np.random.default_rng(1))
        assert detect(scan, np.array(pose), room, PeopleConfig()) == []

    @pytest.mark.parametrize(("px", "py"), [(4.5, 3.0), (1.0, 2.8), (3.2, 0.6)])
    def test_a_person_on_two_legs_is_found_where_they_stand(self, room: DistanceGrid,
                                                            px: float, py: float) -> None:
        """One person, in the robot's frame within 10 cm of where their legs are."""
        pose = (3.0, 3.0, 0.3)
        scan = scan_at(pose, np.random.default_rng(2), extra=legs(px, py, 1.0))
        found = detect(scan, np.array(pose), room, PeopleConfig())
        assert len(found) == 1
        want = to_robot(pose, px, py)
        assert math.dist((found[0].x_m, found[0].y_m), want) < 0.1

    def test_a_body_far_out_is_found_with_fewer_than_ten_points(self,
                                                                room: DistanceGrid) -> None:
        """A 0.4 m body at 2.9 m: about 9 points, kept (the seed's 10 would miss it)."""
        pose = (0.6, 3.0, 0.0)
        scan = scan_at(pose, np.random.default_rng(3), extra=circle(3.5, 3.0, 0.2))
        found = detect(scan, np.array(pose), room, PeopleConfig())
        assert len(found) == 1 and found[0].kind == "body" and found[0].points < 10

    def test_a_wide_box_and_stray_points_are_not_people(self, room: DistanceGrid) -> None:
        """A 1 m box is too wide; two lone returns are too few."""
        pose = (3.0, 3.0, 0.0)
        box = [(4.0, 2.6, 5.0, 2.6), (5.0, 2.6, 5.0, 3.6), (5.0, 3.6, 4.0, 3.6),
               (4.0, 3.6, 4.0, 2.6)]
        scan = scan_at(pose, np.random.default_rng(4), extra=box)
        ranges = scan.ranges_m.copy()
        ranges[100] = ranges[300] = 0.8  # two stray returns, far apart
        stray = type(scan)(scan.angles_rad, ranges, scan.intensities, scan.t_s)
        assert detect(stray, np.array(pose), room, PeopleConfig()) == []


    def test_a_person_right_behind_across_the_sweeps_wrap_is_one_cluster(
            self, room: DistanceGrid) -> None:
        """Legs at bearing +-180 degrees (the scan starts and ends on them): one person."""
        pose = (3.0, 3.0, 0.0)
        scan = scan_at(pose, np.random.default_rng(57070), extra=legs(1.13, 2.92, -0.65))
        found = detect(scan, np.array(pose), room, PeopleConfig())
        assert len(found) == 1 and found[0].width_m < 0.4


class TestTracker:
    def test_a_walker_keeps_one_id_and_gets_a_velocity(self, room: DistanceGrid) -> None:
        """Walking 1 m/s past the robot: one track id throughout, velocity ~ (1, 0) m/s."""
        tracker = PeopleTracker(PeopleConfig(), room)
        rng = np.random.default_rng(5)
        pose = (3.0, 2.4, 1.57)
        ids = set()
        last = []
        for i in range(15):
            x = 1.0 + 0.1 * i
            t = i * 0.1
            last = tracker.update(scan_at(pose, rng, extra=legs(x, 3.2), t_s=t),
                                  np.array(pose), t)
            assert len(last) == 1
            ids.add(last[0].track_id)
        assert ids == {1}
        assert last[0].vx_mps == pytest.approx(1.0, abs=0.25)
        assert last[0].vy_mps == pytest.approx(0.0, abs=0.25)
        assert math.dist((last[0].map_x_m, last[0].map_y_m), (2.4, 3.2)) < 0.1

    def test_a_track_lost_for_longer_than_its_timeout_comes_back_new(
            self, room: DistanceGrid) -> None:
        """Unseen for more than track_timeout_s: the same person gets a new id."""
        tracker = PeopleTracker(PeopleConfig(track_timeout_s=1.0), room)
        rng = np.random.default_rng(6)
        pose = np.array([3.0, 2.4, 1.57])
        first = tracker.update(scan_at(tuple(pose), rng, extra=legs(2.0, 3.2)), pose, 0.0)
        tracker.update(scan_at(tuple(pose), rng), pose, 0.5)
        again = tracker.update(scan_at(tuple(pose), rng, extra=legs(2.0, 3.2)), pose, 2.0)
        assert first[0].track_id == 1 and again[0].track_id == 2


# Feature: relaybot-autonomous-delivery, Property 25: For any person detected by LiDAR, the
# detection should include valid (x, y) coordinates relative to the robot.
@settings(max_examples=100, deadline=None)
@given(px=st.floats(0.6, 5.4), py=st.floats(2.5, 3.5), facing=st.floats(-math.pi, math.pi),
       heading=st.floats(-math.pi, math.pi), seed=st.integers(0, 2**16))
def test_property_25_people_come_with_robot_frame_coordinates(
        px: float, py: float, facing: float, heading: float, seed: int) -> None:
    """A person within 3 m is detected; every detection has finite robot-frame x, y within
    reach of the scan, matching its map-frame position; one lies at the person's place."""
    pose = (3.0, 3.0, heading)
    assume(0.6 <= math.dist(pose[:2], (px, py)) <= 3.0)
    room = _ROOM
    scan = scan_at(pose, np.random.default_rng(seed), extra=legs(px, py, facing))
    people = PeopleTracker(PeopleConfig(), room).update(scan, np.array(pose), 0.0)
    assert people
    for p in people:
        assert math.isfinite(p.x_m) and math.isfinite(p.y_m)
        assert p.range_m <= PeopleConfig().max_range_m
        mx, my = (pose[0] + math.cos(heading) * p.x_m - math.sin(heading) * p.y_m,
                  pose[1] + math.sin(heading) * p.x_m + math.cos(heading) * p.y_m)
        assert math.dist((mx, my), (p.map_x_m, p.map_y_m)) < 1e-9
    want = to_robot(pose, px, py)
    assert min(math.dist((p.x_m, p.y_m), want) for p in people) < 0.2


_ROOM = grid()
