"""Doubles for the line follower's tests: a camera showing a line where told, motors that
record commands, and the follower built from default settings."""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Callable
from typing import Any

import numpy as np

from behaviours.line.follow import LineFollower
from behaviours.line.tracker import LineReading
from hal.devices import LinkDown
from hal.readings import Frame, LinkStats, MotorCommand
from robotd.config.loader import defaults
from robotd.config.settings import Settings

WIDTH, HEIGHT = 320, 240


def line_image(column: float | None) -> np.ndarray:  # type: ignore[type-arg]
    """A light floor with a 30 px dark line centred on ``column`` (None: bare floor)."""
    image = np.full((HEIGHT, WIDTH, 3), 200, np.uint8)
    if column is not None:
        lo, hi = max(0, round(column) - 15), min(WIDTH, round(column) + 15)
        image[:, lo:hi] = 30
    return image


class FreshCamera:
    """A camera with a new frame whenever asked; the test sets what it shows."""

    name = "camera"
    width_px = WIDTH
    height_px = HEIGHT

    def __init__(self, column: float | None = WIDTH / 2) -> None:
        self.image = line_image(column)
        self.seq = 0
        self.frozen = False

    def show(self, column: float | None) -> None:
        self.image = line_image(column)

    async def start(self) -> None:
        return None

    async def close(self) -> None:
        return None

    async def stop(self) -> None:
        return None

    def status(self) -> dict[str, Any]:
        return {}

    def latest(self) -> Frame | None:
        if not self.frozen:
            self.seq += 1
        return Frame(self.image, self.seq, asyncio.get_running_loop().time())

    async def next_reading(self) -> Frame:
        await asyncio.Event().wait()  # a frozen camera never delivers
        raise AssertionError


class RecordingMotors:
    """Motors that record commands with their loop time; can be unplugged or made slow."""

    name = "motors"

    def __init__(self) -> None:
        self.commands: list[tuple[float, MotorCommand]] = []
        self.stops = 0
        self.connected = True
        self.delay_s = 0.0

    async def start(self) -> None:
        return None

    async def close(self) -> None:
        return None

    def unplug(self) -> None:
        self.connected = False

    def plug_in(self) -> None:
        self.connected = True

    async def drive(self, command: MotorCommand) -> None:
        if self.delay_s:
            await asyncio.sleep(self.delay_s)
        if not self.connected:
            raise LinkDown("motor board link is down")
        self.commands.append((asyncio.get_running_loop().time(), command))

    async def stop(self) -> None:
        self.stops += 1

    def on_link_change(self, callback: Callable[[bool], None]) -> None:
        return None

    def link_stats(self) -> LinkStats:
        return LinkStats(connected=self.connected)

    def status(self) -> dict[str, Any]:
        return {}


def make(**overrides: Any) -> tuple[LineFollower, FreshCamera, RecordingMotors, Settings]:
    settings = Settings(defaults())
    for key, value in overrides.items():
        settings.set(f"line_follow.{key}", value)
    camera, motors = FreshCamera(), RecordingMotors()
    return LineFollower(camera, motors, settings), camera, motors, settings


def seen(error_px: float) -> LineReading:
    return LineReading(error_px, 1.0, False, WIDTH / 2 + error_px)


LOST = LineReading(0.0, 0.0, True, reason="no line")


async def run_for(follower: LineFollower, seconds: float) -> BaseException | None:
    task = asyncio.create_task(follower.run())
    await asyncio.sleep(seconds)
    if task.done():
        return task.exception()
    task.cancel()
    with contextlib.suppress(asyncio.CancelledError):
        await task
    return None
