"""The simulated camera's C helpers (line placement, the room light's coarse field), noise
draws and paint reuse give exactly what the plain Python steps give."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from camera_floor import LOOP_AND_SPUR
from hypothesis import given, settings
from hypothesis import strategies as st

from sim.devices.camera_model import CameraMount, SimCamera, _Shot
from sim.world.body import DiffDriveBody
from sim.world.floor_plan import PaintedLine, World
from sim.world.geometry import Pose, segments_array

coords = st.floats(-3.0, 3.0, allow_nan=False)
points = st.lists(st.tuples(coords, coords), min_size=2, max_size=12)
lines = st.lists(st.builds(lambda pts, closed, colour, width: PaintedLine(
    "l", tuple(pts), colour, width, closed), points, st.booleans(),
    st.sampled_from(["black", "red", "blue"]), st.floats(0.001, 0.08)), min_size=1, max_size=3)
# Some poses on the lines (points within the view's reach), some anywhere, any heading.
poses = st.builds(Pose, st.floats(-3.2, 3.2), st.floats(-3.2, 3.2),
                  st.floats(-4 * math.pi, 4 * math.pi))


def bits(placed: Any) -> Any:
    """Placement results with every float as its exact bits (-0.0 and 0.0 differ)."""
    if placed is None:
        return None
    points, *box = placed
    return points, [float(v).hex() for v in box]


def camera(painted: list[PaintedLine], pose: Pose) -> SimCamera:
    world = World(8.0, 8.0, segments_array([]), lines=painted)
    return SimCamera(world, DiffDriveBody(world, pose), seed=2)


def test_segments_of_no_length_and_far_ones() -> None:
    """A zero-length segment is a point; segments beyond the view are not placed."""
    dot = PaintedLine("dot", ((1.0, 1.0), (1.0, 1.0)), "black", 0.02)
    far = PaintedLine("far", ((5.0, 5.0), (6.0, 5.0)), "black", 0.02)
    cam = camera([dot, far], Pose(0.85, 1.0, 0.0))
    at = Pose(0.85, 1.0, 0.0)
    placed = cam._place_segments(cam._line_paint(dot), at, 1.0, 0.0)
    assert placed is not None
    assert len(placed[0]) == 1 and placed[0][0][0] == placed[0][0][1]
    assert cam._place_segments(cam._line_paint(far), at, 1.0, 0.0) is None


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), size=st.sampled_from([(240, 320), (17, 16), (480, 640)]))
def test_noise_offsets_drawn_ahead_are_those_drawn_one_by_one(
        seed: int, size: tuple[int, int]) -> None:
    """The camera's noise offsets are the row-then-column draws of its generator, in order."""

    world = World(4.0, 4.0, segments_array([]))
    pose = Pose(1.0, 1.0, 0.0)
    cam = SimCamera(world, DiffDriveBody(world, pose),
                    CameraMount(width_px=size[1], height_px=size[0]), seed=seed)
    one_by_one = np.random.Generator(np.random.PCG64())
    one_by_one.bit_generator.state = cam._rng.bit_generator.state
    for _ in range(600):
        expected = (int(one_by_one.integers(0, size[0])), int(one_by_one.integers(0, size[1])))
        assert cam._noise_offset() == expected


ROWS = [40, 70, 100, 130, 160, 190, 200, 210]
shots = st.lists(st.tuples(
    st.builds(Pose, st.floats(0.3, 3.7), st.sampled_from([0.5, 2.5, 1.5]).flatmap(
        lambda y: st.floats(y - 0.15, y + 0.15)), st.floats(-math.pi, math.pi)),
    st.tuples(st.floats(-0.6, 0.6), st.floats(-0.6, 0.6)) | st.just((0.0, 0.0)),
    st.sampled_from(["rows", "whole", "rows then whole"])), min_size=1, max_size=8)


@settings(max_examples=60, deadline=None)
@given(sequence=shots)
def test_a_camera_reusing_its_paint_draws_what_a_fresh_one_draws(
        sequence: list[tuple[Pose, tuple[float, float], str]]) -> None:
    """Frames and rows drawn one after another (the floor put back where the last paint
    touched it, a whole frame after its rows reusing their lines) are a fresh camera's."""
    used = camera(list(LOOP_AND_SPUR), Pose(1.0, 0.5, 0.0))
    for i, (pose, wheel_mps, what) in enumerate(sequence):
        shot = _Shot(i, 0.0, pose, wheel_mps, (i, 2 * i))
        fresh = camera(list(LOOP_AND_SPUR), pose)
        if what != "whole":
            assert np.array_equal(used._render_rows(shot, ROWS), fresh._render_rows(shot, ROWS))
        if what != "rows":
            fresh = camera(list(LOOP_AND_SPUR), pose)
            assert np.array_equal(used._render_shot(shot), fresh._render_shot(shot))
