"""A map_server map as the simulated world: its occupied cells stop the body and the beams."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from sim.devices.ld19 import walls as ld19_walls
from sim.world.body import BodyParams, DiffDriveBody
from sim.world.floor_plan import World, WorldError
from sim.world.geometry import Pose, raycast
from sim.world.occupancy_walls import occupied_edges


def _map(tmp_path: Path) -> Path:
    """A 40 x 20 cell map (0.1 m) with origin (-2, -1): a 2 x 2 cell block at x 0..0.2,
    y 0..0.2 and a wall along x = 1.5, all with negative coordinates around them."""
    image = np.full((20, 40), 254, dtype=np.uint8)
    image[20 - 12:20 - 10, 20:22] = 0  # rows 10-11 from the bottom: y 0.0..0.2
    image[:, 35] = 0  # x 1.5..1.6
    (tmp_path / "m.pgm").write_bytes(b"P5\n40 20\n255\n" + image.tobytes())
    (tmp_path / "m.yaml").write_text("image: m.pgm\nresolution: 0.1\norigin: [-2.0, -1.0, 0]\n"
                                     "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n")
    return tmp_path


class TestMapWorld:
    def test_occupied_cells_outline_is_merged_into_runs(self) -> None:
        """A block of cells gives its four sides, each one segment."""
        occupied = np.zeros((4, 4), dtype=np.bool_)
        occupied[1:3, 1:3] = True
        edges = occupied_edges(occupied, 0.5, -1.0, -1.0)
        assert sorted(map(tuple, edges.tolist())) == [
            (-0.5, -0.5, -0.5, 0.5), (-0.5, -0.5, 0.5, -0.5), (-0.5, 0.5, 0.5, 0.5),
            (0.5, -0.5, 0.5, 0.5)]

    def test_beams_stop_at_the_first_occupied_cell_side(self, tmp_path: Path) -> None:
        """A ray from (-1, 0.1) eastwards hits the block's west side at x = 0."""
        world = World.from_table({"map": "m.yaml"}, base_dir=_map(tmp_path))
        got = raycast(world.walls, -1.0, 0.1, np.array([0.0, math.pi / 2]), 12.0)
        assert got[0] == pytest.approx(1.0)
        lidar = ld19_walls(world.walls.tolist(), x_m=-1.0, y_m=-0.5)
        assert lidar(np.array([0.0]))[0] == pytest.approx(2.5)  # the wall at x = 1.5
        assert world.x_min_m < -1.0 and world.y_min_m < -0.5  # the floor spans the map

    def test_the_body_is_stopped_by_occupied_cells(self, tmp_path: Path) -> None:
        """Driving east at the block: a collision, and the body stays out of it."""
        world = World.from_table({"map": "m.yaml"}, base_dir=_map(tmp_path))
        body = DiffDriveBody(world, Pose(-1.0, 0.1, 0.0), BodyParams(slip_std=0))
        body.apply_pwm(200, 200, True, True)
        for _ in range(600):
            body.step(0.01)
        assert body.collisions
        assert body.pose.x_m < 0.0 - body.params.radius_m + 0.02

    def test_a_bad_map_names_the_key_and_the_file(self, tmp_path: Path) -> None:
        """world.map that does not parse: 'world.map: PATH: what is wrong'."""
        (tmp_path / "m.yaml").write_text("image: m.pgm\n")
        with pytest.raises(WorldError, match=r"world\.map: .*m\.yaml: resolution: required"):
            World.from_table({"map": "m.yaml"}, base_dir=tmp_path)
