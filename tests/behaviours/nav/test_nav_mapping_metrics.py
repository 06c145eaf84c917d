"""The relation metric (Kümmerle et al. 2009) and the map-quality figures."""

from __future__ import annotations

import math

import numpy as np
import pytest

from behaviours.nav.icp import Pose
from behaviours.nav.mapping.metrics import map_quality, relation_error
from behaviours.nav.mapping.scan import compose
from hal.occupancy_map import FREE, OCCUPIED, UNKNOWN, OccupancyMap

PATH: list[Pose] = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (2.0, 0.0, math.pi / 2),
                    (2.0, 1.0, math.pi / 2)]


class TestRelationError:
    def test_is_zero_for_the_same_trajectory_in_another_frame(self) -> None:
        """The metric compares relative motions: moving a whole trajectory costs nothing."""
        moved = [compose((5.0, -3.0, 1.0), p) for p in PATH]
        for pairs in ("consecutive", "all"):
            e = relation_error(moved, PATH, pairs=pairs)
            assert e.translation_m < 1e-9 and e.rotation_rad < 1e-9

    def test_measures_a_step_that_is_too_long(self) -> None:
        """One step 10 cm too long: a tenth of it per consecutive pair of the three."""
        est = [PATH[0], (1.1, 0.0, 0.0), (2.1, 0.0, math.pi / 2), (2.1, 1.0, math.pi / 2)]
        e = relation_error(est, PATH)
        assert e.pairs == 3
        assert e.translation_m == pytest.approx(0.1 / 3)
        assert e.translation_max_m == pytest.approx(0.1)
        assert e.rotation_rad == pytest.approx(0.0, abs=1e-12)

    def test_refuses_trajectories_of_different_lengths(self) -> None:
        """Pairs are pairs of the same poses: lengths must match."""
        with pytest.raises(ValueError, match="same length"):
            relation_error(PATH[:2], PATH)


def _grid(cells: list[list[int]], res: float = 0.1, x0: float = 0.0) -> OccupancyMap:
    return OccupancyMap(np.asarray(cells, dtype=np.int8), res, x0, 0.0)


class TestMapQuality:
    def test_a_map_against_itself_is_perfect(self) -> None:
        """Every occupied cell is on a wall, every free cell free."""
        truth = _grid([[OCCUPIED, FREE, FREE], [OCCUPIED, FREE, UNKNOWN]])
        q = map_quality(truth, truth)
        assert (q.occupied_near_wall_pct, q.free_truly_free_pct) == (100.0, 100.0)

    def test_a_wall_one_cell_off_counts_two_cells_off_does_not(self) -> None:
        """Within one cell of a true wall is right; two cells away is wrong."""
        truth = _grid([[OCCUPIED, FREE, FREE, FREE]])
        one = _grid([[FREE, OCCUPIED, FREE, FREE]])
        two = _grid([[FREE, FREE, OCCUPIED, FREE]])
        assert map_quality(one, truth).occupied_near_wall_pct == 100.0
        assert map_quality(two, truth).occupied_near_wall_pct == 0.0
        assert map_quality(two, truth).free_truly_free_pct == pytest.approx(100 * 2 / 3)
