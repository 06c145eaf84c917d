"""The line follower closing the loop over the simulated camera and body, in virtual time."""

from __future__ import annotations

import asyncio
import contextlib
import math
from collections.abc import Callable
from typing import Any

import pytest

from behaviours.line.follow import LineFollower, LineLostError
from hal.readings import LinkStats, MotorCommand
from robotd.config.loader import defaults
from robotd.config.settings import Settings
from sim import vclock
from sim.devices.camera_model import SimCamera
from sim.world.body import DiffDriveBody
from sim.world.floor_plan import PaintedLine, World
from sim.world.geometry import Pose, segments_array

PHYSICS_DT_S = 0.01


class BodyMotors:
    """Motors that put each command straight on the body's H-bridges (no serial link)."""

    name = "motors"

    def __init__(self, body: DiffDriveBody) -> None:
        self.body = body
        self.commands: list[MotorCommand] = []
        self.connected = True

    async def start(self) -> None:
        return None

    async def drive(self, command: MotorCommand) -> None:
        self.commands.append(command)
        self.body.apply_pwm(command.left_pwm, command.right_pwm, command.left_forward,
                            command.right_forward)

    async def stop(self) -> None:
        self.body.apply_pwm(0, 0, True, True)

    async def close(self) -> None:
        await self.stop()

    def on_link_change(self, callback: Callable[[bool], None]) -> None:
        return None

    def link_stats(self) -> LinkStats:
        return LinkStats(connected=True)

    def status(self) -> dict[str, Any]:
        return {}


def _arc(cx: float, cy: float, r: float, a0_deg: float, a1_deg: float, n: int = 24
         ) -> list[tuple[float, float]]:
    return [(cx + r * math.cos(math.radians(a0_deg + (a1_deg - a0_deg) * i / n)),
             cy + r * math.sin(math.radians(a0_deg + (a1_deg - a0_deg) * i / n)))
            for i in range(n + 1)]


def stadium_world(second_colour: str = "red") -> World:
    """A 3 m x 1.6 m stadium loop: black bottom straight and right bend, then a second colour."""
    first = [(1.5, 1.2), *_arc(4.5, 2.0, 0.8, -90, 90)]
    second = [(4.5, 2.8), *_arc(1.5, 2.0, 0.8, 90, 270)]
    return World(6.0, 4.0, segments_array([]), lines=[
        PaintedLine("black-part", tuple(first), "black", 0.025),
        PaintedLine("colour-part", tuple(second), second_colour, 0.025),
    ])


JUNCTIONS = (((4.5, 2.8), "red"), ((1.5, 1.2), "black"))


async def physics(body: DiffDriveBody) -> None:
    while True:
        await asyncio.sleep(PHYSICS_DT_S)
        body.step(PHYSICS_DT_S)


async def fleet_server(body: DiffDriveBody, follower: LineFollower, changes: list[str]) -> None:
    """Like the fleet exchange, once a second: name the colour of the stretch ahead."""
    while True:
        await asyncio.sleep(1.0)
        pose = body.pose
        for (jx, jy), colour in JUNCTIONS:
            ahead = (jx - pose.x_m) * math.cos(pose.heading_rad) + (
                jy - pose.y_m) * math.sin(pose.heading_rad)
            if pose.distance_to(jx, jy) < 0.6 and ahead > 0 and follower.tracker.colour != colour:
                follower.set_follow_colour(colour)
                changes.append(colour)


class TestClosedLoop:
    def test_follows_a_loop_with_a_colour_change_within_3_cm(self) -> None:
        """60 s at about 0.3 m/s on a two-colour loop: mean cross-track error under 3 cm."""
        result = vclock.run(self._drive(60.0))
        print(result)
        assert result["error"] is None
        assert result["mean_cross_track_m"] < 0.03
        assert result["distance_m"] > 0.25 * 60 * 0.85
        assert result["changes"][:2] == ["red", "black"]
        assert result["status"]["overruns"] == 0

    def test_stops_with_an_error_when_the_colour_never_changes(self) -> None:
        """Following black onto the red stretch with no FollowColor: the robot stops."""
        result = vclock.run(self._drive(40.0, server=False))
        assert isinstance(result["error"], LineLostError)
        assert result["stopped"]
        assert result["status"]["state"] == "lost"
        assert result["status"]["lost_count"] == 21

    async def _drive(self, duration_s: float, *, server: bool = True) -> dict[str, Any]:
        world = stadium_world()
        body = DiffDriveBody(world, Pose(2.0, 1.2, 0.0))
        camera = SimCamera(world, body, seed=7)
        motors = BodyMotors(body)
        follower = LineFollower(camera, motors, Settings(defaults()))
        changes: list[str] = []
        errors: list[float] = []
        await camera.start()
        tasks = [asyncio.create_task(physics(body))]
        if server:
            tasks.append(asyncio.create_task(fleet_server(body, follower, changes)))
        run = asyncio.create_task(follower.run())
        error: BaseException | None = None
        loop = asyncio.get_running_loop()
        end = loop.time() + duration_s
        while loop.time() < end and not run.done():
            await asyncio.sleep(0.1)
            errors.append(world.cross_track_m(body.pose.x_m, body.pose.y_m))
        if run.done():
            error = run.exception()
        else:
            run.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await run
        for task in tasks:
            task.cancel()
        await camera.close()
        return {"error": error, "mean_cross_track_m": sum(errors) / len(errors),
                "max_cross_track_m": max(errors), "distance_m": body.distance_m,
                "changes": changes, "status": follower.status(),
                "stopped": body.pwm[:2] == (0, 0)}


if __name__ == "__main__":  # pragma: no cover - manual tuning aid
    pytest.main([__file__, "-s"])
