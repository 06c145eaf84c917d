"""The line follower shows the live view whole camera frames; the tracker reads rows only."""

from __future__ import annotations

import asyncio
from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt
from test_line_follow_closed_loop import BodyMotors

from behaviours.line.follow import LineFollower
from hal.readings import LidarScan
from hal.telemetry import Image, Pose2D
from robotd.config.loader import defaults
from robotd.config.settings import Settings
from sim import vclock
from sim.devices.camera_model import SimCamera
from sim.world.body import DiffDriveBody
from sim.world.floor_plan import PaintedLine, World
from sim.world.geometry import Pose, segments_array


class ViewTelemetry:
    """A live view that takes every third image it is offered."""

    enabled = True

    def __init__(self) -> None:
        self.offered = 0
        self.images: list[npt.NDArray[np.uint8]] = []

    def image(self, topic: str, image: Image, *, marks: Sequence[tuple[int, int]] = ()) -> None:
        self.offered += 1
        if self.offered % 3 == 1:
            self.images.append(image() if callable(image) else image)

    def sample(self, topic: str, /, **fields: Any) -> None: ...
    def values(self, topic: str, /, **fields: Any) -> None: ...
    def pose(self, topic: str, pose: Pose2D, *, frame: str = "map",
             child_frame: str | None = None) -> None: ...
    def poses(self, topic: str, poses: Any, *, frame: str = "map") -> None: ...
    def scan(self, topic: str, scan: LidarScan, *, frame: str = "base_link") -> None: ...
    def path(self, topic: str, points: Any, *, frame: str = "map") -> None: ...
    def grid(self, topic: str, occupied: Any, resolution_m: float,
             origin_xy_m: tuple[float, float], *, frame: str = "map") -> None: ...
    def graph(self, topic: str, nodes: Any, edges: Any, *, frame: str = "map",
              warn: bool = False) -> None: ...


def test_the_view_gets_whole_frames_and_only_its_frames_are_drawn() -> None:
    """1 s of following at 13 FPS: the view is offered a frame at most every 0.1 s; its
    frames are whole 320 x 240 images (the line in them), and only those are drawn whole."""
    world = World(6.0, 4.0, segments_array([]), lines=[
        PaintedLine("l", ((0.5, 2.0), (5.5, 2.0)), "black", 0.025)])
    body = DiffDriveBody(world, Pose(1.0, 2.0, 0.0))
    camera = SimCamera(world, body, seed=5)
    view = ViewTelemetry()
    follower = LineFollower(camera, BodyMotors(body), Settings(defaults()), telemetry=view)
    drawn: list[bool] = []
    latest = camera.latest

    def spy() -> Any:
        frame = latest()
        if frame is not None:
            drawn.append(frame.drawn)
        return frame

    camera.latest = spy  # type: ignore[method-assign]

    async def main() -> None:
        await camera.start()
        run = asyncio.create_task(follower.run())
        await asyncio.sleep(1.0)
        run.cancel()
        await asyncio.gather(run, return_exceptions=True)
        await camera.close()

    vclock.run(main())
    assert 7 <= view.offered <= 10 and len(view.images) == (view.offered + 2) // 3
    for image in view.images:
        assert image.shape == (240, 320, 3) and image.dtype == np.uint8
        assert image[:, 150:170].mean() < image[:, :40].mean() - 30  # the line down the middle
    assert follower.frames >= 12 and not any(drawn)
