"""The distance field: exact Euclidean distance to the nearest obstacle cell."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from behaviours.nav.distance_field import DistanceField
from behaviours.nav.grid import Grid


def _brute_force(occupied: np.ndarray, res: float) -> np.ndarray:
    rows, cols = np.nonzero(occupied)
    out = np.full(occupied.shape, math.inf)
    for r in range(occupied.shape[0]):
        for c in range(occupied.shape[1]):
            if rows.size:
                out[r, c] = np.min(np.hypot(rows - r, cols - c)) * res
    return out


class TestDistanceField:
    @given(arrays(np.bool_, st.tuples(st.integers(1, 14), st.integers(1, 14)),
                  elements=st.booleans()))
    @settings(max_examples=60, deadline=None)
    def test_matches_a_brute_force_search(self, occupied: np.ndarray) -> None:
        """Every cell's value is the distance to the nearest obstacle centre (float32)."""
        field = DistanceField(Grid(occupied, 0.05))
        np.testing.assert_allclose(field.distance_m, _brute_force(occupied, 0.05),
                                   rtol=1e-5, atol=1e-6)

    def test_points_read_their_cell_and_outside_is_zero(self) -> None:
        """Lookups use the cell holding the point, in the map frame; outside is 0."""
        occupied = np.zeros((10, 10), dtype=np.bool_)
        occupied[0, 0] = True
        field = DistanceField(Grid(occupied, 0.1, -1.0, -1.0))
        assert field.at(-0.95, -0.95) == 0.0
        assert math.isclose(field.at(-0.05, -0.95), 0.9, rel_tol=1e-6)
        assert field.at(5.0, 5.0) == 0.0
        got = field.at_points(np.array([-0.05, 9.0]), np.array([-0.95, 0.0]))
        np.testing.assert_allclose(got, [0.9, 0.0], rtol=1e-6)
