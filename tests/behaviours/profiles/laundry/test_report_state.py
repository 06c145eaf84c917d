"""What the laundry robot tells the server of itself in the data exchange (issue 27): its state
path, the e-stop, the fault that keeps it from its job, and its battery."""

from __future__ import annotations

import asyncio
from datetime import UTC, datetime
from typing import Any

from behaviours.context import RobotContext
from behaviours.motion.obstacle_guard import ObstacleGuard
from behaviours.profiles.laundry.report import BLOCKED_FAULT_S, RobotReport
from hal.backend import Devices
from hal.readings import BatteryReading
from robotd.config import Settings
from robotd.config.loader import defaults
from sim import vclock


class DictStore(dict[str, Any]):
    def put(self, key: str, value: Any) -> None:
        self[key] = value

    def delete(self, key: str) -> None:
        self.pop(key, None)

    async def flush(self) -> None:
        pass


class Machine:
    """Fires ``fault`` into recovery and ``recovered`` back to idle, as the real tables do."""

    def __init__(self) -> None:
        self.state = "mission.to_room"

    async def trigger(self, name: str, **_kwargs: Any) -> bool:
        self.state = {"fault": "recovery", "recovered": "idle"}.get(name, self.state)
        return True


class Battery:
    def latest(self) -> BatteryReading:
        return BatteryReading(11.4, 61.04, False, False, 0.0)


class Motors:
    name = "motors"
    connected = True

    async def drive(self, _command: Any) -> None: ...
    async def stop(self) -> None: ...


class Range:
    def __init__(self) -> None:
        self.cm = 100.0

    def latest(self) -> Any:
        from hal.readings import RangeReading

        return RangeReading(self.cm, asyncio.get_running_loop().time())


def _robot(guard: ObstacleGuard | None = None) -> tuple[RobotContext, RobotReport, Machine]:
    ctx = RobotContext(Devices(battery=Battery()), Settings(defaults()), DictStore(),
                       lambda: datetime(2026, 1, 1, tzinfo=UTC), lambda kind, **f: None)
    machine = Machine()
    ctx.attach(machine)
    report = RobotReport("laundry-1", ctx.wall_clock, None, None, None, None,  # type: ignore[arg-type]
                         ctx=ctx, guard=guard)
    return ctx, report, machine


class TestRobotState:
    def test_a_robot_at_work_reports_its_state_and_battery_and_no_fault(self) -> None:
        ctx, report, _ = _robot()
        assert report.robot_state(ctx) == {"State": "mission.to_room",
                                           "EmergencyStopActive": False, "Fault": None,
                                           "BatteryPct": 61.0}

    def test_a_fault_is_reported_while_the_robot_is_in_recovery(self) -> None:
        """Line lost: code and message while in recovery; gone once recovered."""
        async def main() -> tuple[Any, Any]:
            ctx, report, _ = _robot()
            await ctx.trigger("fault", code="line_lost", reason="no line for 13 frames")
            during = report.robot_state(ctx)
            await ctx.trigger("recovered")
            return during, report.robot_state(ctx)

        during, after = vclock.run(main())
        assert during["State"] == "recovery"
        assert during["Fault"] == {"Code": "line_lost", "Message": "no line for 13 frames"}
        assert after["Fault"] is None

    def test_a_latched_estop_is_reported(self) -> None:
        async def main() -> dict[str, Any]:
            ctx, report, _ = _robot()
            await ctx.estop_latch.set("robotctl", "test")
            return report.robot_state(ctx)

        assert vclock.run(main())["EmergencyStopActive"] is True

    def test_a_block_ahead_that_lasts_is_a_fault_blocked(self) -> None:
        """Stopped by something ahead: not a fault at first, ``blocked`` after
        BLOCKED_FAULT_S, gone when the way is clear."""
        async def main() -> list[Any]:
            front = Range()
            guard = ObstacleGuard(Motors(), front, Settings(defaults()))  # type: ignore[arg-type]
            ctx, report, _ = _robot(guard)
            front.cm = 5.0
            from hal.readings import MotorCommand

            await guard.drive(MotorCommand(100, 100))
            seen = [report.robot_state(ctx)["Fault"]]
            await asyncio.sleep(BLOCKED_FAULT_S + 1)
            seen.append(report.robot_state(ctx)["Fault"])
            front.cm = 100.0
            await guard.drive(MotorCommand(100, 100))
            seen.append(report.robot_state(ctx)["Fault"])
            return seen

        first, later, cleared = vclock.run(main())
        assert first is None
        assert later["Code"] == "blocked" and "obstacle ahead" in later["Message"]
        assert cleared is None
