"""The simulated camera's rows drawn alone are the bytes of those rows of the whole frame."""

from __future__ import annotations

import asyncio
import math

import numpy as np
import pytest
from camera_floor import loop_world
from hypothesis import given, settings
from hypothesis import strategies as st

from hal.readings import Frame
from sim import vclock
from sim.devices.camera_model import CameraMount, SimCamera, _Shot
from sim.world.body import DiffDriveBody
from sim.world.geometry import Pose

WORLD = loop_world()
# Near the lines (paint to light and blur), and anywhere on a wide floor (far texture tiles).
poses = st.one_of(
    st.builds(lambda x, y, heading: Pose(x, 0.5 + y / 10, heading), st.floats(0.3, 3.7),
              st.floats(-1.0, 1.0), st.floats(-math.pi, math.pi)),
    st.builds(Pose, st.floats(-200.0, 200.0), st.floats(-200.0, 200.0),
              st.floats(-math.pi, math.pi)))
wheels = st.tuples(st.floats(-1.2, 1.2), st.floats(-1.2, 1.2))  # blur kernels up to 13 px
noise_at = st.tuples(st.integers(0, 239), st.integers(0, 319))
row_sets = st.lists(st.integers(0, 239), max_size=40)


@settings(max_examples=80, deadline=None)
@given(pose=poses, wheel_mps=wheels, at=noise_at, covered=st.booleans(), rows=row_sets,
       whole_first=st.booleans())
def test_rows_drawn_alone_are_the_rows_of_the_whole_frame(
        pose: Pose, wheel_mps: tuple[float, float], at: tuple[int, int],
        covered: bool, rows: list[int], whole_first: bool) -> None:
    """Any rows (any order, repeated or none), covered or not, drawn before or after the
    whole frame: byte for byte the frame's (the blur and the light of a band included)."""
    camera = SimCamera(WORLD, DiffDriveBody(WORLD, pose), seed=4)
    shot = _Shot(1, 0.0, pose, wheel_mps, at, covered)
    if whole_first:
        whole = camera._render_shot(shot)
        alone = camera._render_rows(shot, rows)
    else:
        alone = camera._render_rows(shot, rows)
        whole = camera._render_shot(shot)
    assert alone.dtype == np.uint8 and alone.shape == (len(rows), 320, 3)
    assert np.array_equal(alone, whole[rows])


@pytest.mark.parametrize("size", [(16, 16), (200, 90), (640, 480)])
def test_rows_alone_at_other_resolutions(size: tuple[int, int]) -> None:
    """Other frame sizes (a texture reached at its mirrored border too) give the same rows."""
    mount = CameraMount(width_px=size[0], height_px=size[1])
    rng = np.random.default_rng(3)
    for _ in range(30):
        pose = Pose(*rng.uniform(-300, 300, 2), rng.uniform(-math.pi, math.pi))
        camera = SimCamera(WORLD, DiffDriveBody(WORLD, pose), mount, seed=6)
        shot = _Shot(1, 0.0, pose, (0.3, 0.1), (3, 5))
        rows = sorted(set(rng.integers(0, size[1], 10).tolist()))
        assert np.array_equal(camera._render_rows(shot, rows), camera._render_shot(shot)[rows])


def test_rows_outside_the_frame_are_refused() -> None:
    """A row index past the frame is an IndexError naming the rows, not a crash."""
    camera = SimCamera(WORLD, DiffDriveBody(WORLD, Pose(1.0, 0.5, 0.0)))
    shot = _Shot(1, 0.0, Pose(1.0, 0.5, 0.0), (0.0, 0.0), (0, 0))
    for rows in ([240], [-1], [3, 500]):
        with pytest.raises(IndexError, match="rows"):
            camera._render_rows(shot, rows)


class TestFrames:
    def test_a_frame_read_by_rows_draws_only_those(self) -> None:
        """The tracker's kind of read leaves the whole image undrawn; reading it later draws
        it once, and its rows are the ones handed out before."""
        camera = SimCamera(WORLD, DiffDriveBody(WORLD, Pose(1.0, 0.5, 0.0)), seed=2)

        async def main() -> tuple[Frame, np.ndarray, np.ndarray]:  # type: ignore[type-arg]
            await camera.start()
            await asyncio.sleep(0.1)
            frame = await camera.next_reading()
            await camera.close()
            rows = frame.rows([60, 90, 143])
            assert not frame.drawn and frame.shape == (240, 320, 3)
            image = frame.image
            assert frame.drawn and frame.image is image
            return frame, rows, image

        frame, rows, image = vclock.run(main())
        assert np.array_equal(rows, image[[60, 90, 143]])
        assert np.array_equal(frame.rows([143, 60]), image[[143, 60]])
        assert camera.frames_rendered == 1

    def test_a_frame_shows_the_lens_as_it_was_at_the_capture(self) -> None:
        """Covered after the capture, before anyone looks: that frame is not dark, the next is."""
        camera = SimCamera(WORLD, DiffDriveBody(WORLD, Pose(1.0, 0.5, 0.0)), seed=2)

        async def main() -> tuple[float, float]:
            await camera.start()
            frame = await camera.next_reading()
            camera.cover()
            after = await camera.next_reading()
            await camera.close()
            return float(frame.rows([100, 120]).mean()), float(after.rows([100, 120]).mean())

        before, after = vclock.run(main())
        assert before > 100 and after < 20

    def test_a_frame_of_an_image_hands_out_its_rows(self) -> None:
        """A camera's plain Frame(image, seq, t_s): rows are the image's, shape is its."""
        image = np.random.default_rng(1).integers(0, 255, (48, 64, 3), dtype=np.uint8)
        frame = Frame(image, 3, 0.5)
        assert frame.drawn and frame.shape == (48, 64, 3) and frame.image is image
        assert np.array_equal(frame.rows([5, 0, 47]), image[[5, 0, 47]])
        assert frame.rows([]).shape == (0, 64, 3)
