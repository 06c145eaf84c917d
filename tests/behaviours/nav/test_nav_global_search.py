"""The global search: the scan alone finds the robot on the whole map, and the filter seeded
with its candidates settles on the true pose while the robot turns."""

from __future__ import annotations

import math
from importlib import resources
from pathlib import Path

import numpy as np
import pytest
from nav_room import drive, grid, odometry_of, scan_at

from behaviours.nav.config import MapConfig, PlannerConfig
from behaviours.nav.localisation.config import LocalisationConfig
from behaviours.nav.localisation.filter import LOCALISED, UNCERTAIN, Localiser
from behaviours.nav.localisation.global_search import GlobalSearch
from behaviours.nav.localisation.likelihood_field import DistanceGrid, select_beams
from behaviours.nav.map_file import grid_of
from behaviours.nav.planner import Planner
from hal.occupancy_map import read_map_yaml
from hal.readings import LidarScan


def _near(poses: np.ndarray, truth: tuple[float, float, float], within_m: float = 0.2,
          within_deg: float = 6.0) -> int:
    off = np.hypot(poses[:, 0] - truth[0], poses[:, 1] - truth[1])
    turn = np.abs(np.remainder(poses[:, 2] - truth[2] + math.pi, 2 * math.pi) - math.pi)
    return int(np.count_nonzero((off < within_m) & (turn < math.radians(within_deg))))


class TestInTheRoom:
    @pytest.mark.parametrize("truth", [(3.0, 3.0, 1.0), (1.0, 4.5, -1.5), (5.5, 3.5, 3.0),
                                       (0.5, 2.0, 0.3)])
    def test_the_true_pose_is_among_the_candidates(self, truth: tuple[float, float, float]
                                                   ) -> None:
        """Every lattice pose scored by one scan: the best include the truth."""
        rng = np.random.default_rng(3)
        search = GlobalSearch(grid())
        beams = select_beams(scan_at(truth, rng), 450, 12.0)
        poses, fit = search.candidates(beams, rng)
        assert _near(poses, truth) > 0
        assert fit > -1.0  # log score per beam: the scan fits somewhere well

    def test_seeded_with_them_the_filter_settles_while_turning(self) -> None:
        """The candidates as particles, a turn on the spot: localised within 5 cm, 3 deg."""
        rng = np.random.default_rng(4)
        truth_pose = (4.5, 3.0, -2.0)
        loc = Localiser(grid(), LocalisationConfig(update_min_a_deg=5.0))
        search = GlobalSearch(loc.grid)
        loc.start_from(search.candidates(select_beams(scan_at(truth_pose, rng), 450, 12.0),
                                         rng)[0])
        loc.mark_uncertain()
        assert loc.status == UNCERTAIN
        truth = drive([truth_pose, (truth_pose[0], truth_pose[1], truth_pose[2] + 2.5)],
                      step_rad=0.1)
        odom = odometry_of(truth, rng)
        for i, (t, o) in enumerate(zip(truth, odom, strict=True)):
            loc.on_scan(o, scan_at(t, rng), i * 0.1)
        p = loc.pose_array(odom[-1])
        assert loc.status == LOCALISED
        assert math.hypot(p[0] - truth[-1][0], p[1] - truth[-1][1]) < 0.05
        assert abs(math.degrees(math.remainder(p[2] - truth[-1][2], math.tau))) < 3.0


@pytest.fixture(scope="module")
def site() -> tuple[GlobalSearch, np.ndarray]:
    """The warehouse map's search, and its occupied cells' sides (the simulator's walls)."""
    from sim.world.occupancy_walls import map_walls

    path = Path(str(resources.files("sim") / "maps" / "warehouse.yaml"))
    occupancy = read_map_yaml(path)
    planner = Planner(grid_of(occupancy, MapConfig()), PlannerConfig())
    distance = DistanceGrid.from_field(planner.field, occupancy.cells == 0)
    return GlobalSearch(distance), map_walls(occupancy)


class TestOnTheWarehouse:
    @pytest.mark.parametrize("truth", [(0.0, 0.0, 0.5), (10.5, 16.0, -1.2),
                                       (-12.0, -20.0, 2.0), (3.6, 0.75, -0.4)])
    def test_a_kidnapped_robot_is_found_on_1_7_million_cells(
            self, site: tuple[GlobalSearch, np.ndarray], truth: tuple[float, float, float]
            ) -> None:
        """On the 30 x 50 m warehouse (racks, aisles), one LD19-like scan: the true pose is
        among the candidates."""
        from sim.world.geometry import raycast

        search, walls = site
        rng = np.random.default_rng(5)
        angles = -math.pi + np.arange(450) * (2 * math.pi / 450)
        ranges = raycast(walls, truth[0], truth[1], angles + truth[2], 12.0)
        ranges = ranges + rng.normal(0.0, 0.01, ranges.shape)
        ranges[ranges >= 12.0] = np.nan
        scan = LidarScan(angles, ranges, np.zeros(450, dtype=np.uint8), 0.0)
        poses, _fit = search.candidates(select_beams(scan, 450, 12.0), rng)
        assert _near(poses, truth) > 0
        assert search.positions > 20000


class TestLostAndReseeded:
    def test_a_settled_filter_that_leaps_counts_a_jump(self) -> None:
        """Localised, then every particle moved 1 m (the filter gone to a look-alike): a
        jump; a filter still converging after its start moves freely."""
        rng = np.random.default_rng(6)
        loc = Localiser(grid(), LocalisationConfig())
        loc.start_at(2.0, 0.5, 0.0, 0.05, 0.05)
        loc.on_scan((0.0, 0.0, 0.0), scan_at((2.0, 0.5, 0.0), rng), 0.0)
        assert loc.status == LOCALISED and loc.jumps == 0
        loc.particles.poses[:, 0] += 1.0
        loc.on_scan((0.3, 0.0, 0.0), scan_at((2.3, 0.5, 0.0), rng), 0.1)
        assert loc.jumps == 1 and loc.last_jump[0] >= 0.5
        fresh = Localiser(grid(), LocalisationConfig())
        fresh.start_at(1.5, 0.5, 0.0)  # 0.5 m off: the first updates may move it far
        fresh.on_scan((0.0, 0.0, 0.0), scan_at((2.0, 0.5, 0.0), rng), 0.0)
        assert fresh.jumps == 0

    def test_a_reseeded_filter_settles_standing_still(self) -> None:
        """An operator's pose 15 cm and 8 deg off, the robot standing: the settling updates
        bring it within 5 cm and localised."""
        rng = np.random.default_rng(7)
        loc = Localiser(grid(), LocalisationConfig())
        loc.start_at(3.15, 2.4, 0.14, 0.2, math.radians(10))
        loc.mark_uncertain()
        for i in range(8):
            loc.on_scan((0.0, 0.0, 0.0), scan_at((3.0, 2.5, 0.0), rng), i * 0.1)
        p = loc.pose_array((0.0, 0.0, 0.0))
        assert loc.status == LOCALISED
        assert math.hypot(p[0] - 3.0, p[1] - 2.5) < 0.05
