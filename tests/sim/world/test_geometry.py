"""Geometry helpers of the simulated world: the one-ray cast agrees with the array cast."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from sim.world.floor_plan import PaintedLine, World
from sim.world.geometry import distance_to_segments, raycast, raycast_one, segments_array

_coord = st.floats(-10, 10, allow_nan=False)
_segment = st.tuples(_coord, _coord, _coord, _coord)


class TestRaycastOne:
    @given(st.lists(_segment, max_size=12), _coord, _coord, st.floats(-7, 7), st.floats(0.1, 5))
    def test_gives_exactly_what_raycast_gives_for_that_ray(
            self, segments: list[tuple[float, float, float, float]], x_m: float, y_m: float,
            angle_rad: float, max_range_m: float) -> None:
        """Same hits, same nearest distance, same max range when nothing is hit."""
        array = segments_array(segments)
        expected = float(raycast(array, x_m, y_m, np.array([angle_rad]), max_range_m)[0])
        assert raycast_one(array.tolist(), x_m, y_m, angle_rad, max_range_m) == expected

    def test_a_wall_ahead_is_hit_at_its_distance(self) -> None:
        """A wall 2 m ahead across the ray: 2 m; the ray pointing away: the max range."""
        wall = [(3.0, -1.0, 3.0, 1.0)]
        assert raycast_one(wall, 1.0, 0.0, 0.0, 5.0) == 2.0
        assert raycast_one(wall, 1.0, 0.0, np.pi, 5.0) == 5.0


LINES = [PaintedLine("loop", ((0.5, 0.5), (3.5, 0.5), (3.5, 2.5), (0.5, 2.5)), "black", 0.025,
                     closed=True),
         PaintedLine("spur", ((2.0, 0.5), (2.0, 0.5), (2.0, 2.5)), "red", 0.02)]


@given(x=st.floats(-5, 10), y=st.floats(-5, 10), n_lines=st.integers(0, 2))
def test_cross_track_is_the_distance_to_the_nearest_line_segment(x: float, y: float,
                                                                 n_lines: int) -> None:
    """World.cross_track_m gives distance_to_segments over the lines' segments, to the bit."""
    world = World(4.0, 3.0, segments_array([]), lines=LINES[:n_lines])
    assert world.cross_track_m(x, y) == distance_to_segments(world.line_segments(), x, y)
    world.lines = LINES[:1]  # replaced lines are seen
    assert world.cross_track_m(x, y) == distance_to_segments(LINES[0].segments(), x, y)
