"""The tracker reading a frame's scan rows only finds what it finds in the whole image."""

from __future__ import annotations

import importlib.util
import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt
import pytest
from camera_floor import loop_world
from hypothesis import given, settings
from hypothesis import strategies as st

from behaviours.line.tracker import LineTracker, TrackerParams
from hal.readings import Frame
from sim.devices.camera_model import CameraMount, SimCamera, _Shot
from sim.world.body import DiffDriveBody
from sim.world.floor_plan import PaintedLine
from sim.world.geometry import Pose

KERNELS = ["numpy", pytest.param("c", marks=pytest.mark.skipif(
    importlib.util.find_spec("behaviours.line._line_scan") is None,
    reason="the C line scan was not built"))]


WORLD = loop_world(PaintedLine("twin", ((0.5, 0.58), (3.5, 0.58)), "black", 0.02))


class ShotPainter:
    """Draws one shot of a simulated camera, counting whole images drawn."""

    def __init__(self, camera: SimCamera, shot: _Shot) -> None:
        self.camera = camera
        self.shot = shot
        self.images = 0
        self.shape = (camera.height_px, camera.width_px, 3)

    def image(self) -> npt.NDArray[np.uint8]:
        self.images += 1
        return self.camera._render_shot(self.shot)

    def rows(self, indices: Sequence[int]) -> npt.NDArray[np.uint8]:
        return self.camera._render_rows(self.shot, indices)


@pytest.mark.parametrize("kernel", KERNELS)
@pytest.mark.parametrize("width_px", [320, 1280])
@settings(max_examples=25, deadline=None)
@given(x=st.floats(0.4, 3.6), y=st.floats(-0.06, 0.12), heading=st.floats(-0.6, 0.6),
       covered=st.booleans(), colour=st.sampled_from([None, "red"]))
def test_a_rows_only_frame_gives_the_reading_of_the_whole_image(
        kernel: str, width_px: int, x: float, y: float, heading: float, covered: bool,
        colour: str | None) -> None:
    """Along a stretch (the tracker remembers the line): readings equal, no image drawn."""
    mount = CameraMount(width_px=width_px, height_px=width_px * 3 // 4,
                        view_width_m=0.24)
    camera = SimCamera(WORLD, DiffDriveBody(WORLD, Pose(x, 0.5 + y, heading)), mount, seed=3)
    by_rows = LineTracker(TrackerParams(), colour, kernel=kernel)
    by_image = LineTracker(TrackerParams(), colour, kernel=kernel)
    for step in range(4):
        pose = Pose(x + 0.02 * step * math.cos(heading), 0.5 + y, heading + 0.05 * step)
        shot = _Shot(step, 0.0, pose, (0.2, 0.25), (7 * step, 11 * step), covered)
        painter = ShotPainter(camera, shot)
        reading = by_rows.track(Frame.painted(painter, step, 0.0))
        assert painter.images == 0
        assert reading == by_image.track(camera._render_shot(shot))


@pytest.mark.parametrize("kernel", KERNELS)
def test_a_frame_of_an_image_reads_as_the_image(kernel: str) -> None:
    """A real camera's Frame(image, ...) and its bare image give the same readings."""
    pose = Pose(1.0, 0.51, 0.1)
    image = SimCamera(WORLD, DiffDriveBody(WORLD, pose), seed=1).render(pose)
    a, b = LineTracker(kernel=kernel), LineTracker(kernel=kernel)
    first = a.track(Frame(image, 1, 0.0))
    assert not first.lost and first == b.track(image)
    with pytest.raises(ValueError, match="BGR"):
        a.track(Frame(image[:, :, 0], 2, 0.0))
