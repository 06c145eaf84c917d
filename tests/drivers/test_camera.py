"""Camera drivers: a recorded video replayed as a camera, and clear errors for missing ones."""

from __future__ import annotations

import asyncio
import importlib.util
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest

from behaviours.line.tracker import LineTracker
from drivers.camera import CaptureCamera, PiCamera, UvcCamera, VideoFileCamera, open_camera, probe
from hal.devices import Camera, DeviceUnavailable
from sim import vclock
from sim.devices.camera_model import SimCamera
from sim.world.body import DiffDriveBody
from sim.world.floor_plan import PaintedLine, World
from sim.world.geometry import Pose, segments_array

WIDTH, HEIGHT = 160, 120


def write_bar_video(path: Path, frames: int = 12, fps: float = 10.0) -> list[int]:
    """A video of a dark vertical bar stepping right; returns the bar's column per frame."""
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), fps, (WIDTH, HEIGHT))
    assert writer.isOpened()
    columns = []
    for i in range(frames):
        image = np.full((HEIGHT, WIDTH, 3), 210, np.uint8)
        col = 20 + i * 10
        image[:, col - 4:col + 4] = 30
        writer.write(image)
        columns.append(col)
    writer.release()
    return columns


def dark_column(image: np.ndarray[Any, Any]) -> int:
    return int(np.argmin(image[:, :, 1].mean(axis=0)))


class TestVideoFileCamera:
    def test_replays_every_frame_in_order_at_the_file_rate(self, tmp_path: Path) -> None:
        """Frames come back in order, same size, at the file's 10 FPS on the loop's clock."""
        path = tmp_path / "run.avi"
        columns = write_bar_video(path)

        async def main() -> tuple[list[int], list[float], Any]:
            camera = VideoFileCamera(path)
            await camera.start()
            frames = [camera.latest()]
            while len(frames) < len(columns):
                frames.append(await camera.next_reading())
            await camera.close()
            assert all(f is not None for f in frames)
            return ([dark_column(f.image) for f in frames if f is not None],
                    [f.t_s for f in frames if f is not None], camera)

        seen, times, camera = vclock.run(main())
        assert isinstance(camera, Camera)
        assert (camera.width_px, camera.height_px) == (WIDTH, HEIGHT)
        assert all(abs(s - c) <= 4 for s, c in zip(seen, columns, strict=True))
        gaps = np.diff(times)
        assert np.allclose(gaps, 0.1, atol=1e-6)

    def test_end_of_the_recording_fails_waiters_with_a_clear_error(self, tmp_path: Path) -> None:
        """After the last frame, next_reading raises DeviceUnavailable naming the file."""
        path = tmp_path / "short.avi"
        write_bar_video(path, frames=3)

        async def main() -> None:
            camera = VideoFileCamera(path, fps=30)
            await camera.start()
            await camera.next_reading()
            await camera.next_reading()
            with pytest.raises(DeviceUnavailable, match=r"short\.avi: end of recording"):
                await camera.next_reading()
            assert camera.ended
            await camera.close()

        vclock.run(main())

    def test_loop_replays_from_the_start(self, tmp_path: Path) -> None:
        """With loop=True the first frame comes again after the last."""
        path = tmp_path / "loop.avi"
        columns = write_bar_video(path, frames=4)

        async def main() -> list[int]:
            camera = VideoFileCamera(path, loop=True)
            await camera.start()
            frames = [await camera.next_reading() for _ in range(6)]
            await camera.close()
            assert camera.rewinds >= 1
            return [dark_column(f.image) for f in frames]

        seen = vclock.run(main())
        assert abs(seen[3] - columns[0]) <= 4

    def test_a_missing_file_is_unavailable(self, tmp_path: Path) -> None:
        """A path that does not exist: DeviceUnavailable saying so."""
        with pytest.raises(DeviceUnavailable, match="no such file"):
            vclock.run(VideoFileCamera(tmp_path / "nope.avi").start())

    def test_a_file_that_is_not_a_video_is_unavailable(self, tmp_path: Path) -> None:
        """Text in a .avi: DeviceUnavailable, not a crash."""
        path = tmp_path / "notes.avi"
        path.write_text("not a video\n")
        with pytest.raises(DeviceUnavailable, match=r"notes\.avi"):
            vclock.run(VideoFileCamera(path).start())

    def test_a_recorded_run_is_tracked_like_the_live_camera(self, tmp_path: Path) -> None:
        """Sim frames recorded to video and replayed: the tracker finds the line where it was."""
        world = World(4, 4, segments_array([]),
                      lines=[PaintedLine("l", ((0.0, 2.0), (4.0, 2.0)), "black", 0.025)])
        body = DiffDriveBody(world, Pose(1.0, 2.0, 0.0))
        sim = SimCamera(world, body, seed=3)
        offsets_m = [-0.04, -0.02, 0.0, 0.02, 0.04]
        path = tmp_path / "recorded.avi"
        writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 13,
                                 (sim.width_px, sim.height_px))
        for off in offsets_m:
            writer.write(sim.render(Pose(1.0, 2.0 + off, 0.0)))
        writer.release()

        async def main() -> list[float]:
            camera = VideoFileCamera(path)
            await camera.start()
            tracker = LineTracker()
            errors = []
            frame = camera.latest()
            for _ in offsets_m:
                assert frame is not None
                reading = tracker.track(frame.image)
                assert not reading.lost
                errors.append(reading.error_px)
                if len(errors) < len(offsets_m):
                    frame = await camera.next_reading()
            await camera.close()
            return errors

        errors = vclock.run(main())
        expected = [off / sim.mount.m_per_px for off in offsets_m]
        assert all(abs(e - x) < 2.0 for e, x in zip(errors, expected, strict=True))

    def test_probe_reports_size_and_rate(self, tmp_path: Path) -> None:
        """probe() reads frames and reports figures a technician can check."""
        path = tmp_path / "probe.avi"
        write_bar_video(path, frames=20, fps=20)
        figures = vclock.run(probe(VideoFileCamera(path), frames=10))
        assert figures["width_px"] == WIDTH
        assert figures["frames"] == 10
        assert figures["fps_measured"] == pytest.approx(20, rel=0.05)


class TestUnavailableCameras:
    def test_a_missing_usb_camera_says_which_device(self) -> None:
        """No /dev/video99: one clear line naming the device and what to check."""
        with pytest.raises(DeviceUnavailable, match=r"/dev/video99: cannot open"):
            asyncio.run(UvcCamera("/dev/video99").start())

    @pytest.mark.skipif(importlib.util.find_spec("picamera2") is not None,
                        reason="picamera2 is installed here")
    def test_the_pi_camera_without_picamera2_says_how_to_get_it(self) -> None:
        """Off a Pi: DeviceUnavailable pointing at python3-picamera2 and the venv option."""
        with pytest.raises(DeviceUnavailable, match=r"python3-picamera2.*system-site-packages"):
            asyncio.run(PiCamera().start())

    def test_open_camera_builds_the_configured_source(self, tmp_path: Path) -> None:
        """The camera section picks the driver; a file source without a file is refused."""
        assert isinstance(open_camera({"source": "uvc", "device": "0"}), UvcCamera)
        assert isinstance(open_camera({"source": "picamera"}), PiCamera)
        camera = open_camera({"source": "file", "file": str(tmp_path / "x.avi"), "loop": True})
        assert isinstance(camera, VideoFileCamera)
        assert camera.loop
        with pytest.raises(DeviceUnavailable, match=r"camera\.file"):
            open_camera({"source": "file", "file": ""})


class ScriptedSource(CaptureCamera):
    """A capture source on the documented subclass hooks that plays back what a capture
    library returned (arrays, None, or an exception to raise), then keeps giving frames."""

    source = "scripted"

    def __init__(self, grabs: list[Any]) -> None:
        super().__init__("scripted", 64, 48, 30.0)
        self.grabs = grabs
        self.opens = 0

    def _open(self) -> None:
        self.opens += 1

    def _grab(self) -> Any:
        item = self.grabs.pop(0) if self.grabs else np.full((48, 64, 3), 99, np.uint8)
        if isinstance(item, Exception):
            raise item
        return item

    def _close(self) -> None:
        pass

    async def _pace(self) -> None:
        await asyncio.sleep(0.01)


class TestOddFrames:
    def test_grey_and_bgra_frames_become_bgr(self) -> None:
        """Grey (h, w) and BGRA frames reach readers as (h, w, 3) BGR, which the tracker
        reads; nothing else is published."""
        grey = np.full((48, 64), 50, np.uint8)
        bgra = np.full((48, 64, 4), 60, np.uint8)

        async def main() -> list[tuple[int, ...]]:
            camera = ScriptedSource([np.full((48, 64, 3), 40, np.uint8), grey, bgra])
            await camera.start()
            shapes = [tuple((await camera.next_reading()).image.shape) for _ in range(2)]
            await camera.close()
            return shapes

        assert vclock.run(main()) == [(48, 64, 3), (48, 64, 3)]

    def test_unusable_frames_and_library_errors_are_counted_not_fatal(self) -> None:
        """Empty, tiny, float or 2-channel frames and an exception from the capture library
        count as failed reads (named in status) and capture goes on."""
        bad: list[Any] = [np.zeros((0, 0, 3), np.uint8), np.zeros((4, 4, 3), np.uint8),
                          np.zeros((48, 64, 3), np.float32), np.zeros((48, 64, 2), np.uint8),
                          RuntimeError("Camera frontend has timed out!")]

        async def main() -> dict[str, Any]:
            camera = ScriptedSource([np.full((48, 64, 3), 40, np.uint8), *bad])
            await camera.start()
            frame = await asyncio.wait_for(camera.next_reading(), 1.0)
            status = camera.status()
            await camera.close()
            assert frame.image.shape == (48, 64, 3)
            return status

        status = vclock.run(main())
        assert status["bad_frames"] == 4 and status["failed_reads"] == 5
        assert "timed out" in status["last_error"]

    def test_a_first_frame_that_cannot_be_used_is_unavailable(self, tmp_path: Path) -> None:
        """A recording of 8x8 frames (or a library error on the first read) fails start()
        with DeviceUnavailable naming the problem, not a crash later in the tracker."""
        path = tmp_path / "tiny.avi"
        writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 10, (8, 8))
        for _ in range(3):
            writer.write(np.full((8, 8, 3), 200, np.uint8))
        writer.release()
        with pytest.raises(DeviceUnavailable, match=r"unusable frames \(shape \(8, 8, 3\)"):
            vclock.run(VideoFileCamera(path).start())
        with pytest.raises(DeviceUnavailable, match=r"cannot read a frame.*USB"):
            vclock.run(ScriptedSource([OSError("USB gone")]).start())
