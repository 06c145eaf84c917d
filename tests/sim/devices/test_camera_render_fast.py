"""The simulated camera's fast paths draw the very frames the plain OpenCV steps draw."""

from __future__ import annotations

import math

import cv2
import numpy as np
from camera_floor import loop_world
from hypothesis import given, settings
from hypothesis import strategies as st

from sim.devices.camera_model import CameraMount, SimCamera, _Shot
from sim.world.body import DiffDriveBody
from sim.world.floor_plan import PaintedLine, World
from sim.world.geometry import Pose, SegmentSet, segment_distances, segments_array

WORLD = loop_world()
# Near the lines, where there is paint to light and blur (the view is 24 x 18 cm).
poses = st.builds(lambda x, y, heading, near_spur: Pose(2.0 + (x - 2) / 20, 1.5 + y, heading)
                  if near_spur else Pose(x, 0.5 + y / 10, heading),
                  st.floats(0.3, 3.7), st.floats(-1.0, 1.0), st.floats(-math.pi, math.pi),
                  st.booleans())
wheels = st.tuples(st.floats(-0.6, 0.6), st.floats(-0.6, 0.6))
noise_at = st.tuples(st.integers(0, 239), st.integers(0, 319))


@settings(max_examples=60, deadline=None)
@given(pose=poses, wheel_mps=wheels)
def test_blurring_around_the_paint_is_blurring_the_whole_frame(
        pose: Pose, wheel_mps: tuple[float, float]) -> None:
    """Motion blur applied to the painted box only leaves the frame as a full blur would."""
    camera = SimCamera(WORLD, DiffDriveBody(WORLD, pose), seed=4)
    painted = camera._paint(pose, wheel_mps).copy()
    image = camera._bare_floor().copy()
    camera._draw_lines(image, pose)
    m = camera.mount
    speed = (wheel_mps[0] + wheel_mps[1]) / 2
    yaw_rps = (wheel_mps[1] - wheel_mps[0]) / camera.body.params.wheel_base_m
    ky = 1 + 2 * round(abs(speed) * m.exposure_s / m.m_per_px / 2)
    kx = 1 + 2 * round(abs(yaw_rps) * m.forward_m * m.exposure_s / m.m_per_px / 2)
    expected = image if kx == ky == 1 else cv2.blur(image, (kx, ky))
    assert np.array_equal(painted, expected)


def test_a_robot_standing_still_gets_the_same_frames_as_a_fresh_camera() -> None:
    """Reusing the paint and light of an unchanged pose changes no pixel; the noise moves."""
    pose = Pose(2.0, 0.52, 0.1)
    a = SimCamera(WORLD, DiffDriveBody(WORLD, pose), CameraMount(), seed=9)
    first = a._render_shot(_Shot(1, 0.0, pose, (0.2, 0.2), (5, 7)))
    second = a._render_shot(_Shot(2, 0.0, pose, (0.2, 0.2), (30, 40)))
    b = SimCamera(WORLD, DiffDriveBody(WORLD, pose), CameraMount(), seed=9)
    assert np.array_equal(second, b._render_shot(_Shot(2, 0.0, pose, (0.2, 0.2), (30, 40))))
    assert not np.array_equal(first, second)


coords = st.floats(-5.0, 5.0)


@given(ends=st.lists(st.tuples(coords, coords, coords, coords), max_size=12), x=coords,
       y=coords)
def test_a_segment_set_measures_as_segment_distances(
        ends: list[tuple[float, float, float, float]], x: float, y: float) -> None:
    """SegmentSet.distances (the camera's per-frame cull) equals segment_distances exactly."""
    segs = segments_array(ends)
    assert np.array_equal(SegmentSet(segs).distances(x, y), segment_distances(segs, x, y))


def test_a_line_painted_while_the_robot_stands_still_shows() -> None:
    """The paint kept for an unchanged pose is redrawn when the world's lines change."""
    pose = Pose(1.0, 1.5, 0.0)
    floor = World(4.0, 3.0, segments_array([]), lines=[])
    camera = SimCamera(floor, DiffDriveBody(floor, pose), seed=2)
    bare = camera._render_shot(_Shot(1, 0.0, pose, (0.0, 0.0), (0, 0)))
    floor.lines.append(PaintedLine("new", ((0.0, 1.5), (4.0, 1.5)), "black", 0.025))
    painted = camera._render_shot(_Shot(2, 0.0, pose, (0.0, 0.0), (0, 0)))
    assert painted.mean() < bare.mean() - 1
