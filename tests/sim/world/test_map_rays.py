"""A map world's thousands of cell sides: the LiDAR's tiles and nearest-first casting, and the
front sensor's nearby walls, give exactly the ranges every wall gives."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from sim.world.body import DiffDriveBody
from sim.world.floor_plan import World
from sim.world.geometry import Pose, raycast_one
from sim.world.lidar_rays import WallTiles, cast_nearest_first, cast_segments

MAPS = Path(__file__).parents[3] / "sim" / "maps"


@pytest.fixture(scope="module", params=["depot.yaml", "warehouse.yaml"])
def world(request: pytest.FixtureRequest) -> World:
    return World.from_table({"map": request.param}, base_dir=MAPS)


def _normals(seg: np.ndarray) -> np.ndarray:
    ex, ey = seg[:, 2] - seg[:, 0], seg[:, 3] - seg[:, 1]
    length = np.hypot(ex, ey)
    length[length == 0] = 1.0
    return np.column_stack((-ey / length, ex / length))


class TestTiledCasting:
    def test_tiles_and_nearest_first_give_the_same_ranges(self, world: World) -> None:
        """From 150 random places and headings, a 72-degree group of 90 beams: the same
        ranges, to the bit, as every segment cast at once."""
        seg = world.walls
        normal = _normals(seg)
        tiles = WallTiles(seg)
        rng = np.random.default_rng(7)
        for _ in range(150):
            x = rng.uniform(world.x_min_m + 1, world.x_min_m + world.width_m - 1)
            y = rng.uniform(world.y_min_m + 1, world.y_min_m + world.height_m - 1)
            angles = rng.uniform(-math.pi, math.pi) + np.linspace(0, math.radians(72), 90)
            full = cast_segments(seg, normal, x, y, angles, math.cos(math.radians(80)))
            idx = tiles.facing(x, y, angles)
            tiled = cast_nearest_first(seg[idx], normal[idx], x, y, angles,
                                       math.cos(math.radians(80)))
            assert np.array_equal(full, tiled)

    def test_a_tile_behind_the_sensor_is_dropped(self) -> None:
        """Walls only behind the beams' arc: no segment reaches the intersection."""
        seg = np.array([[-5.0 - 0.1 * i, -1.0, -5.0 - 0.1 * i, 1.0] for i in range(300)])
        tiles = WallTiles(seg)
        assert tiles.facing(0.0, 0.0, np.linspace(-0.5, 0.5, 30)).size == 0
        assert tiles.facing(0.0, 0.0, np.linspace(math.pi - 0.5, math.pi, 30)).size > 0


class TestFrontSensor:
    def test_the_nearby_walls_give_the_same_range(self, world: World) -> None:
        """The front sensor's cached nearby walls: the range every wall gives, as the robot
        moves about (the cache renewed as it goes)."""
        body = DiffDriveBody(world, Pose(0.0, 0.0, 0.0))
        walls = world.walls.tolist()
        rng = np.random.default_rng(8)
        x = world.x_min_m + world.width_m / 2
        y = world.y_min_m + world.height_m / 2
        for _ in range(300):
            x += rng.normal(0, 0.3)
            y += rng.normal(0, 0.3)
            heading = rng.uniform(-math.pi, math.pi)
            near = body._walls_near(x, y, 1.5)
            assert raycast_one(near, x, y, heading, 1.5) == raycast_one(walls, x, y, heading, 1.5)
