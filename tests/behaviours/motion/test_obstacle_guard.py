"""The obstacle guard: no forward motion with something close ahead; turning still allowed."""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from typing import Any

from behaviours.motion.obstacle_guard import ObstacleGuard
from hal.latest import LatestValue
from hal.readings import LinkStats, MotorCommand, RangeReading
from robotd.config.loader import defaults
from robotd.config.settings import Settings
from sim import vclock


class WheelLog:
    """Records what reaches the wheels."""

    name = "wheels"
    connected = True

    def __init__(self) -> None:
        self.sent: list[MotorCommand] = []

    async def start(self) -> None: ...
    async def close(self) -> None: ...

    def status(self) -> dict[str, Any]:
        return {}

    async def drive(self, command: MotorCommand) -> None:
        self.sent.append(command)

    async def stop(self) -> None:
        self.sent.append(MotorCommand.stopped())

    def on_link_change(self, callback: Callable[[bool], None]) -> None: ...

    def link_stats(self) -> LinkStats:
        return LinkStats(connected=True)


class FrontSensor:
    def __init__(self) -> None:
        self.value: LatestValue[RangeReading] = LatestValue()

    def read(self, cm: float) -> None:
        self.value.publish(RangeReading(cm, asyncio.get_running_loop().time()))

    def latest(self) -> RangeReading | None:
        return self.value.latest()

    async def next_reading(self) -> RangeReading:
        return await self.value.next()


FORWARD = MotorCommand(150, 150, True, True)
SPIN = MotorCommand(100, 100, False, True)


class TestObstacleGuard:
    def test_forward_motion_stops_close_to_an_obstacle_and_resumes_past_the_hysteresis(
        self,
    ) -> None:
        async def main() -> list[bool]:
            wheels, front = WheelLog(), FrontSensor()
            guard = ObstacleGuard(wheels, front, Settings(defaults()))
            moving = []
            for cm in (100, 25, 35, 45):  # stop below 30 cm, resume above 40 cm
                front.read(cm)
                await guard.drive(FORWARD)
                moving.append(not wheels.sent[-1].is_stop)
            return moving

        assert vclock.run(main()) == [True, False, False, True]

    def test_turning_in_place_and_reversing_pass_while_blocked(self) -> None:
        async def main() -> list[MotorCommand]:
            wheels, front = WheelLog(), FrontSensor()
            guard = ObstacleGuard(wheels, front, Settings(defaults()))
            front.read(10)
            await guard.drive(SPIN)
            await guard.drive(MotorCommand(120, 120, False, False))
            return wheels.sent

        assert vclock.run(main()) == [SPIN, MotorCommand(120, 120, False, False)]

    def test_no_recent_reading_counts_as_blocked(self) -> None:
        """Without a fresh front reading the robot does not drive blind."""

        async def main() -> list[bool]:
            wheels, front = WheelLog(), FrontSensor()
            guard = ObstacleGuard(wheels, front, Settings(defaults()))
            await guard.drive(FORWARD)  # never a reading
            front.read(120)
            await guard.drive(FORWARD)
            await asyncio.sleep(2.0)  # the reading grows old
            await guard.drive(FORWARD)
            return [c.is_stop for c in wheels.sent]

        assert vclock.run(main()) == [True, False, True]

    def test_blocks_are_counted_and_reported(self) -> None:
        async def main() -> tuple[int, list[str]]:
            events: list[str] = []
            wheels, front = WheelLog(), FrontSensor()
            guard = ObstacleGuard(wheels, front, Settings(defaults()),
                                  lambda kind, **_f: events.append(kind))
            for cm in (100, 20, 100, 20):
                front.read(cm)
                await guard.drive(FORWARD)
            return guard.blocks, events

        assert vclock.run(main()) == (2, ["guard.blocked", "guard.clear", "guard.blocked"])
