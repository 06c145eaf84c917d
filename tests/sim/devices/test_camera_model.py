"""The simulated downward camera: geometry, colours, light, noise, blur and frame timing."""

from __future__ import annotations

import asyncio
import math

import numpy as np
import pytest

from hal.devices import Camera
from sim import vclock
from sim.devices.camera_model import CameraMount, SimCamera
from sim.world.body import DiffDriveBody
from sim.world.floor_plan import LINE_COLOURS_BGR, PaintedLine, World
from sim.world.geometry import Pose, segments_array


def world_with(*lines: PaintedLine) -> World:
    return World(6.0, 6.0, segments_array([]), lines=list(lines))


def east_line(y_m: float = 3.0, colour: str = "black") -> PaintedLine:
    return PaintedLine("l", ((0.0, y_m), (6.0, y_m)), colour, 0.025)


def line_column(image: np.ndarray, row: int) -> float:  # type: ignore[type-arg]
    darkness = 255.0 - image[row].astype(np.float32).mean(axis=1)
    darkness -= np.median(darkness)
    darkness[darkness < 40] = 0
    return float((darkness * np.arange(darkness.size)).sum() / darkness.sum())


class TestGeometry:
    def test_a_line_under_the_robot_is_in_the_middle_column(self) -> None:
        """Driving along the line's centre, the line runs down the image centre."""
        world = world_with(east_line())
        camera = SimCamera(world, DiffDriveBody(world, Pose(1.0, 3.0, 0.0)))
        image = camera.render(Pose(1.0, 3.0, 0.0))
        for row in (20, 120, 220):
            assert line_column(image, row) == pytest.approx((camera.width_px - 1) / 2, abs=1.0)

    def test_a_line_to_the_right_appears_right_by_its_offset_in_pixels(self) -> None:
        """3 cm to the right of the robot is 3 cm / (metres per pixel) right of the centre."""
        world = world_with(east_line())
        camera = SimCamera(world, DiffDriveBody(world, Pose(1.0, 3.03, 0.0)))
        image = camera.render(Pose(1.0, 3.03, 0.0))
        expected = (camera.width_px - 1) / 2 + 0.03 / camera.mount.m_per_px
        assert line_column(image, 120) == pytest.approx(expected, abs=1.0)

    def test_heading_tilts_the_line_across_the_image(self) -> None:
        """Turned left of the line, the line drifts right as it goes up (farther ahead)."""
        world = world_with(east_line())
        pose = Pose(1.0, 3.0, math.radians(10))
        image = SimCamera(world, DiffDriveBody(world, pose)).render(pose)
        assert line_column(image, 10) > line_column(image, 230) + 10

    def test_floor_to_pixel_and_back_agree(self) -> None:
        """The mount's two conversions are inverse to each other."""
        mount = CameraMount()
        pose = Pose(2.0, 1.0, 0.7)
        x, y = mount.px_to_floor(pose, 37.0, 201.0)
        col, row = mount.floor_to_px(pose, x, y)
        assert (col, row) == (pytest.approx(37.0), pytest.approx(201.0))

    def test_it_is_a_hal_camera_with_the_mounts_size(self) -> None:
        """A `hal.devices.Camera`; width and height come from the mount."""
        world = world_with(east_line())
        camera = SimCamera(world, DiffDriveBody(world, Pose(1, 3, 0)),
                           CameraMount(width_px=640, height_px=480))
        assert isinstance(camera, Camera)
        assert camera.render(Pose(1, 3, 0)).shape == (480, 640, 3)

    def test_bad_mounts_are_refused(self) -> None:
        """A tiny resolution or a zero rate is an error naming the value."""
        with pytest.raises(ValueError, match="resolution"):
            CameraMount(width_px=4)
        with pytest.raises(ValueError, match="fps"):
            CameraMount(fps=0)


class TestLook:
    def test_the_line_has_its_paint_colour(self) -> None:
        """A red line is red in the frame (BGR), within lighting and noise."""
        world = world_with(east_line(colour="red"))
        image = SimCamera(world, DiffDriveBody(world, Pose(1, 3, 0))).render(Pose(1, 3, 0))
        b, g, r = image[100:140, 150:170].reshape(-1, 3).mean(axis=0)
        assert r > 2 * g and r > 2 * b
        assert LINE_COLOURS_BGR["red"][2] * 0.7 < r < 255

    def test_the_floor_is_textured_lit_unevenly_and_noisy(self) -> None:
        """Bare floor is not flat: texture and noise inside, darker corners than centre."""
        world = world_with()
        image = SimCamera(world, DiffDriveBody(world, Pose(1, 3, 0))).render(Pose(1, 3, 0))
        grey = image.astype(np.float32).mean(axis=2)
        assert grey[100:140, 140:180].std() > 2
        assert grey[:20, :20].mean() < grey[110:130, 150:170].mean() * 0.9

    def test_the_same_seed_gives_the_same_frames(self) -> None:
        """Two cameras with one seed render the same image; another seed differs."""
        world = world_with(east_line())
        body = DiffDriveBody(world, Pose(1, 3, 0))
        a = SimCamera(world, body, seed=5).render(Pose(1, 3, 0))
        b = SimCamera(world, body, seed=5).render(Pose(1, 3, 0))
        c = SimCamera(world, body, seed=6).render(Pose(1, 3, 0))
        assert np.array_equal(a, b)
        assert not np.array_equal(a, c)

    def test_driving_fast_blurs_the_edges_of_a_crossing_line(self) -> None:
        """A line across the path has softer edges when the wheels turn fast."""
        world = world_with(PaintedLine("x", ((1.15, 0.0), (1.15, 6.0)), "black", 0.025))
        camera = SimCamera(world, DiffDriveBody(world, Pose(1, 3, 0)),
                           CameraMount(noise_std=0.0, texture_std=0.0))
        still = camera.render(Pose(1, 3, 0), (0.0, 0.0)).astype(np.float32)
        moving = camera.render(Pose(1, 3, 0), (0.6, 0.6)).astype(np.float32)
        edge_still = np.abs(np.diff(still[:, 160, 1])).max()
        edge_moving = np.abs(np.diff(moving[:, 160, 1])).max()
        assert edge_moving < 0.6 * edge_still

    def test_a_covered_lens_gives_dark_frames(self) -> None:
        """cover(): the frame is nearly black."""
        world = world_with(east_line())
        camera = SimCamera(world, DiffDriveBody(world, Pose(1, 3, 0)))
        camera.cover()
        assert camera.render(Pose(1, 3, 0)).mean() < 20


class TestTiming:
    def test_frames_arrive_at_the_mount_rate_on_the_loop_clock(self) -> None:
        """At 20 FPS, consecutive frames are 50 ms apart in loop time, numbered in order."""
        world = world_with(east_line())
        body = DiffDriveBody(world, Pose(1, 3, 0))
        camera = SimCamera(world, body, CameraMount(fps=20))

        async def main() -> list[tuple[int, float]]:
            await camera.start()
            got = []
            for _ in range(5):
                frame = await camera.next_reading()
                got.append((frame.seq, frame.t_s))
            await camera.close()
            return got

        got = vclock.run(main())
        seqs = [s for s, _ in got]
        assert seqs == list(range(seqs[0], seqs[0] + 5))
        assert np.allclose(np.diff([t for _, t in got]), 0.05)

    def test_a_frame_shows_the_pose_at_its_capture_time(self) -> None:
        """The robot moves after capture: latest() still shows where it was."""
        world = world_with(east_line())
        body = DiffDriveBody(world, Pose(1.0, 3.0, 0.0))
        camera = SimCamera(world, body, CameraMount(fps=10))

        async def main() -> tuple[float, float]:
            await camera.start()
            await camera.next_reading()
            body.pose = Pose(1.0, 3.05, 0.0)
            frame = camera.latest()
            assert frame is not None
            before = line_column(frame.image, 120)
            frame = await camera.next_reading()
            after = line_column(frame.image, 120)
            await camera.close()
            return before, after

        before, after = vclock.run(main())
        assert before == pytest.approx(159.5, abs=1.0)
        assert after > before + 50

    def test_frames_nobody_looks_at_are_not_rendered(self) -> None:
        """Captures cost nothing until latest() or a waiter asks for the image."""
        world = world_with(east_line())
        camera = SimCamera(world, DiffDriveBody(world, Pose(1, 3, 0)), CameraMount(fps=30))

        async def main() -> None:
            await camera.start()
            await asyncio.sleep(1.0)
            await camera.close()

        vclock.run(main())
        assert camera.frames_captured >= 30
        assert camera.frames_rendered == 0
