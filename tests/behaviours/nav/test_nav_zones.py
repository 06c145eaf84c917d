"""Zones: Nav2's keep-out and speed masks read from files, kept out of by the planner, and the
speed limit on the path ahead."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest

from behaviours.nav.config import PlannerConfig, ZoneConfig
from behaviours.nav.grid import Grid
from behaviours.nav.planner import NoPath, Planner, min_distance_to_path
from behaviours.nav.zones import NO_LIMIT, SpeedRule, Zones, mask_path, mask_values
from hal.occupancy_map import OccupancyMap, read_map_yaml

RES = 0.05
SIZE = (80, 120)  # rows, cols: a 6 x 4 m room


def _room() -> Grid:
    occupied = np.zeros(SIZE, dtype=np.bool_)
    occupied[0, :] = occupied[-1, :] = occupied[:, 0] = occupied[:, -1] = True
    return Grid(occupied, RES)


def _mask(cells: np.ndarray) -> OccupancyMap:
    return OccupancyMap(cells.astype(np.int8), RES, 0.0, 0.0, "mask")


def _block(x0: float, y0: float, x1: float, y1: float, value: int) -> np.ndarray:
    cells = np.zeros(SIZE, dtype=np.int8)
    cells[round(y0 / RES):round(y1 / RES), round(x0 / RES):round(x1 / RES)] = value
    return cells


def _write_pgm_yaml(directory: Path, name: str, cells: np.ndarray, mode: str) -> Path:
    """A mask as Nav2's tutorials draw one: grey levels in a PGM, top row first."""
    shade = np.rint(255 * (1.0 - cells.astype(np.float64) / 100.0)).astype(np.uint8)[::-1]
    rows, cols = shade.shape
    (directory / f"{name}.pgm").write_bytes(f"P5\n{cols} {rows}\n255\n".encode() + shade.tobytes())
    thresholds = ("occupied_thresh: 0.65\nfree_thresh: 0.25\n" if mode == "trinary"
                  else "occupied_thresh: 1.0\nfree_thresh: 0.0\n")
    yaml = directory / f"{name}.yaml"
    yaml.write_text(f"image: {name}.pgm\nmode: {mode}\nresolution: {RES}\n"
                    f"origin: [0.0, 0.0, 0]\nnegate: 0\n{thresholds}")
    return yaml


class TestSpeedRule:
    def test_nav2_percent_convention(self) -> None:
        """base 100, multiplier -1: value v limits to 100 - v percent; 0, unknown and a
        limit of 0 (v = 100: Nav2's controller reads 0 as no limit) are no limit."""
        rule = SpeedRule(percent=True, base=100.0, multiplier=-1.0)
        limits = rule.limits(np.array([0, 20, 50, -1, 100], dtype=np.int16))
        assert limits[1] == 80.0 and limits[2] == 50.0
        assert np.isnan(limits[[0, 3, 4]]).all()
        assert rule.mps(50.0, 0.2) == pytest.approx(0.1)

    def test_out_of_range_limits_are_no_limit(self) -> None:
        """A percentage above 100 or a speed at or below 0 is no limit, as Nav2 warns."""
        assert np.isnan(SpeedRule(True, 150.0, 0.0).limits(np.array([10], dtype=np.int16)))[0]
        absolute = SpeedRule(False, 0.5, -0.01)
        assert absolute.limits(np.array([30], dtype=np.int16))[0] == pytest.approx(0.2)
        assert np.isnan(absolute.limits(np.array([60], dtype=np.int16)))[0]
        assert absolute.mps(0.2, 99.0) == 0.2


class TestSpeedLimitAhead:
    def test_the_lowest_limit_within_the_lookahead(self) -> None:
        """A 50 % zone 0.3 m ahead on the path is in force now; one 1 m ahead is not yet."""
        zones = Zones(speed=_mask(_block(2.0, 0.0, 3.0, 4.0, 50)), lookahead_m=0.4)
        ahead = zones.limit_along([(1.75, 2.0), (4.0, 2.0)], top_mps=0.2)
        assert ahead.limit_mps == pytest.approx(0.1) and ahead.value == 50
        assert zones.limit_along([(1.0, 2.0), (4.0, 2.0)], top_mps=0.2) == NO_LIMIT
        assert zones.limit_at(2.5, 2.0, 0.2).limit_mps == pytest.approx(0.1)

    def test_no_speed_mask_no_limit(self) -> None:
        """Without a speed mask nothing is limited."""
        assert Zones().limit_along([(1.0, 1.0), (2.0, 1.0)], 0.2) == NO_LIMIT

    def test_off_the_mask_is_unknown(self) -> None:
        """Points off the mask read -1 (unknown: no limit)."""
        mask = _mask(_block(0.0, 0.0, 6.0, 4.0, 50))
        assert mask_values(mask, np.array([-1.0, 1.0]), np.array([1.0, 1.0])).tolist() == [-1, 50]


class TestKeepout:
    def test_the_planner_goes_round_a_keepout_zone(self) -> None:
        """A zone across the straight line: the path keeps every point, and every cell it
        crosses, out of it, with the margin."""
        grid = _room()
        zones = Zones(keepout=_mask(_block(2.5, 0.0, 3.5, 3.0, 100)), keepout_margin_m=0.1)
        planner = Planner(grid, PlannerConfig(), keepout=zones.keepout_for(grid))
        plan = planner.plan((1.0, 1.0), (5.0, 1.0))
        pts = np.array(plan.points)
        fine = np.concatenate([np.linspace(a, b, 200) for a, b in itertools.pairwise(pts)])
        assert zones.keepout is not None
        assert not (mask_values(zones.keepout, fine[:, 0], fine[:, 1]) >= 100).any()
        # every point of the path keeps the margin from every keep-out cell's centre
        rows, cols = np.nonzero(zones.keepout_cells(grid))
        centres = np.column_stack(((cols + 0.5) * RES, (rows + 0.5) * RES))
        assert min_distance_to_path(plan.points, centres) >= 0.1 - 1e-9
        assert plan.length_m > 6.0  # round the zone, not the straight 4 m

    def test_a_goal_in_a_zone_is_no_path_saying_so(self) -> None:
        """A goal inside a keep-out zone: NoPath goal_in_keepout."""
        grid = _room()
        zones = Zones(keepout=_mask(_block(2.5, 0.0, 3.5, 3.0, 100)))
        planner = Planner(grid, PlannerConfig(), keepout=zones.keepout_for(grid))
        with pytest.raises(NoPath, match="keep-out") as caught:
            planner.plan((1.0, 1.0), (3.0, 1.0))
        assert caught.value.reason == "goal_in_keepout"
        assert planner.in_keepout((3.0, 1.0)) and not planner.in_keepout((1.0, 1.0))

    def test_a_start_in_the_margin_plans_its_way_out(self) -> None:
        """A robot the tracking error put in the margin round a zone is not stuck."""
        grid = _room()
        zones = Zones(keepout=_mask(_block(2.5, 0.0, 3.5, 3.0, 100)), keepout_margin_m=0.2)
        planner = Planner(grid, PlannerConfig(), keepout=zones.keepout_for(grid))
        plan = planner.plan((2.4, 1.0), (1.0, 1.0))
        assert plan.points[-1] == (1.0, 1.0)

    def test_obstacles_seen_keep_the_zones(self) -> None:
        """A planner with obstacles added still keeps out of the zones."""
        grid = _room()
        zones = Zones(keepout=_mask(_block(2.5, 0.0, 3.5, 3.0, 100)))
        planner = Planner(grid, PlannerConfig(), keepout=zones.keepout_for(grid))
        assert planner.with_obstacles([(1.0, 3.0)]).keepout is planner.keepout


class TestFiles:
    def test_masks_are_read_beside_the_map(self, tmp_path: Path) -> None:
        """Relative mask names are beside the map file; Nav2's grey levels become values."""
        _write_pgm_yaml(tmp_path, "keepout", _block(2.5, 0.0, 3.5, 3.0, 100), "trinary")
        _write_pgm_yaml(tmp_path, "speed", _block(4.0, 0.0, 5.0, 4.0, 50), "scale")
        config = ZoneConfig(keepout_file="keepout.yaml", speed_file="speed.yaml")
        zones = Zones.from_config(config, tmp_path / "site.yaml")
        assert zones.active
        assert zones.in_keepout(3.0, 1.0) and not zones.in_keepout(1.0, 1.0)
        assert zones.limit_at(4.5, 1.0, 0.2).limit_mps == pytest.approx(0.1)
        assert zones.describe()["speed_type"] == "percent"
        assert mask_path("/abs/m.yaml", tmp_path / "site.yaml") == Path("/abs/m.yaml")

    def test_no_files_no_zones(self) -> None:
        """The defaults give no zones."""
        zones = Zones.from_config(ZoneConfig(), None)
        assert not zones.active
        assert zones.keepout_for(_room()) is None

    def test_the_depot_masks_are_nav2s(self) -> None:
        """The depot's masks: its racks kept out of, 50 % among the pallets, 75 % among the
        racks, Nav2's percent rule."""
        from importlib import resources

        maps = Path(str(resources.files("sim") / "maps"))
        keepout = read_map_yaml(maps / "depot_keepout.yaml")
        zones = Zones(keepout=keepout, speed=read_map_yaml(maps / "depot_speed.yaml"))
        assert zones.in_keepout(17.2, 10.0) and not zones.in_keepout(19.15, 10.5)
        assert zones.limit_at(20.0, 4.0, 0.2).limit == 50.0
        assert zones.limit_at(19.15, 10.5, 0.2).limit == 75.0
        assert zones.limit_at(5.0, 5.0, 0.2) == NO_LIMIT
        assert math.isclose(keepout.resolution_m, 0.05)


class TestCheckConfig:
    def test_a_mask_that_does_not_parse_is_a_problem_on_its_line(self, tmp_path: Path) -> None:
        """check-config reads the masks beside the map file: a missing one is a problem
        naming map.keepout_file and its line; good ones are none."""
        from behaviours.nav.zones import zone_file_problems

        _write_pgm_yaml(tmp_path, "site", np.zeros(SIZE, dtype=np.int8), "trinary")
        _write_pgm_yaml(tmp_path, "speed", _block(4.0, 0.0, 5.0, 4.0, 50), "scale")
        config = str(tmp_path / "robotd.toml")
        values: dict[str, dict[str, object]] = {"map": {
            "file": "site.yaml", "keepout_file": "nowhere.yaml", "speed_file": "speed.yaml"}}
        problems = zone_file_problems(values, config, {("map", "keepout_file"): 7})
        assert len(problems) == 1
        assert (problems[0].key, problems[0].line) == ("map.keepout_file", 7)
        assert "nowhere.yaml" in problems[0].message
        values["map"]["keepout_file"] = ""
        assert zone_file_problems(values, config, {}) == []
