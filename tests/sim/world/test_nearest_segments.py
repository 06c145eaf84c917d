"""NearestSegments gives the brute-force minimum distance to segments, to the bit."""

from __future__ import annotations

import itertools
import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from sim.world.geometry import NearestSegments, SegmentSet, segments_array

_coord = st.floats(-20.0, 20.0, allow_nan=False)
_segment = st.tuples(_coord, _coord, _coord, _coord)
_point = st.tuples(_coord, _coord)


def _brute(segments: SegmentSet, x_m: float, y_m: float) -> float:
    return float(segments.distances(x_m, y_m).min())


def _same_bits(a: float, b: float) -> bool:
    return np.float64(a).tobytes() == np.float64(b).tobytes()


@settings(max_examples=300)
@given(segments=st.lists(_segment, min_size=1, max_size=30),
       points=st.lists(_point, min_size=1, max_size=20),
       cell_m=st.sampled_from([0.05, 0.1, 0.5, 3.0]))
def test_equals_the_minimum_over_all_segments(
        segments: list[tuple[float, float, float, float]],
        points: list[tuple[float, float]], cell_m: float) -> None:
    """For any segments (degenerate ones too) and points, the same float as the brute force."""
    ends = SegmentSet(segments_array(segments))
    nearest = NearestSegments(ends, cell_m)
    for x, y in points:
        assert _same_bits(nearest.min_distance(x, y), _brute(ends, x, y))


@settings(max_examples=200)
@given(start=_point, steps=st.lists(st.floats(0.0, 0.3), min_size=3, max_size=12),
       points=st.lists(st.tuples(st.floats(-1.0, 1.0), st.floats(-1.0, 1.0)), min_size=1,
                       max_size=30))
def test_equals_the_brute_force_near_a_painted_polyline(
        start: tuple[float, float], steps: list[float],
        points: list[tuple[float, float]]) -> None:
    """Points near a line of short joined segments (a painted line) and on its vertices."""
    x, y = start
    vertices = [(x, y)]
    for i, step in enumerate(steps):
        x, y = x + step * math.cos(i), y + step * math.sin(i)
        vertices.append((x, y))
    ends = SegmentSet(segments_array([(*a, *b) for a, b in itertools.pairwise(vertices)]))
    nearest = NearestSegments(ends)
    for dx, dy in [*points, (0.0, 0.0)]:
        for vx, vy in vertices:
            assert _same_bits(nearest.min_distance(vx + dx, vy + dy), _brute(ends, vx + dx,
                                                                               vy + dy))


def test_no_segments_is_infinitely_far_and_far_points_fall_back() -> None:
    """No segments: inf; points out of the grid's range: the brute force."""
    assert NearestSegments(SegmentSet(segments_array([]))).min_distance(1.0, 2.0) == math.inf
    ends = SegmentSet(segments_array([(0.0, 0.0, 1.0, 0.0)]))
    nearest = NearestSegments(ends)
    for x, y in [(1e5, 3.0), (-2e4, 1e9), (math.inf, 0.0)]:
        assert _same_bits(nearest.min_distance(x, y), _brute(ends, x, y))
