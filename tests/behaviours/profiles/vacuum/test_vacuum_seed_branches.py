"""Issue 28: the vacuum's seed branches: a battery that cannot be read is a fault, standby
waits for the cleaning schedule, and cleaning turns away from a virtual wall."""

from __future__ import annotations

import asyncio
import random
from datetime import UTC, datetime, timedelta

import pytest
from docking_doubles import Rig

from behaviours.profiles.vacuum.cleaning import Coverage
from behaviours.profiles.vacuum.profile import BATTERY_UNREADABLE, VacuumProfile
from behaviours.profiles.vacuum.schedule import Schedule, ScheduleError, schedule_problems
from hal.readings import BatteryReading
from robotd.config import Settings
from robotd.config.loader import defaults
from sim import vclock

THURSDAY = datetime(2026, 1, 1, tzinfo=UTC)  # the simulator's epoch is a Thursday


class TestUnreadableBattery:
    def test_no_reading_is_a_fault_not_a_full_battery(self) -> None:
        """The check cannot tell when to dock: it reports the fault (recovery, robotctl
        status) instead of cleaning on."""
        rig = Rig("mission.battery_check")
        rig.battery.value = None
        vclock.run(VacuumProfile()._battery_check(rig.ctx))
        name, fields = rig.machine.fired[0]
        assert name == "fault" and fields["code"] == BATTERY_UNREADABLE
        assert "no battery reading yet" in fields["reason"]
        assert rig.events[-1][0] == "clean.battery_unreadable"

    def test_a_stale_reading_is_a_fault_too(self) -> None:
        rig = Rig("mission.battery_check")

        async def main() -> None:
            rig.battery.value = BatteryReading(12.0, 80.0, False, False, 0.0)
            await asyncio.sleep(float(rig.settings.get("vacuum.battery_stale_s")) + 1)
            await VacuumProfile()._battery_check(rig.ctx)

        vclock.run(main())
        assert rig.machine.fired[0][1]["code"] == BATTERY_UNREADABLE

    def test_the_fault_shows_while_the_robot_is_in_recovery(self) -> None:
        rig = Rig("mission.battery_check", moves={"fault": "recovery"})
        rig.battery.value = None
        vclock.run(VacuumProfile()._battery_check(rig.ctx))
        assert rig.ctx.fault is not None and rig.ctx.fault.code == BATTERY_UNREADABLE


class TestSchedule:
    def test_the_next_start_is_the_first_after_now(self) -> None:
        schedule = Schedule.parse({"thu": ["09:00", "14:30"], "mon": "08:15"}, "UTC")
        assert schedule.next_start(THURSDAY) == THURSDAY + timedelta(hours=9)
        after = THURSDAY + timedelta(hours=10)
        assert schedule.next_start(after) == THURSDAY + timedelta(hours=14, minutes=30)
        late = THURSDAY + timedelta(hours=15)
        assert schedule.next_start(late) == THURSDAY + timedelta(days=4, hours=8, minutes=15)

    def test_daily_and_an_empty_schedule(self) -> None:
        daily = Schedule.parse({"daily": "00:00"}, "UTC")
        assert daily.next_start(THURSDAY) == THURSDAY + timedelta(days=1)
        assert Schedule.parse({}).next_start(THURSDAY) is None

    def test_a_local_time_zone(self) -> None:
        """09:00 in Berlin in winter is 08:00 UTC."""
        schedule = Schedule.parse({"thu": "09:00"}, "Europe/Berlin")
        start = schedule.next_start(THURSDAY)
        assert start is not None and start.astimezone(UTC) == THURSDAY + timedelta(hours=8)

    @pytest.mark.parametrize(("table", "message"), [
        ({"monday": "09:00"}, "'monday' is not a day"),
        ({"mon": "9:00"}, "expected a time"),
        ({"mon": ["09:00", "25:00"]}, "expected a time"),
        ({"mon": 900}, "expected a time"),
    ])
    def test_a_bad_entry_is_named(self, table: dict[str, object], message: str) -> None:
        with pytest.raises(ScheduleError, match=message):
            Schedule.parse(table)

    def test_check_config_reports_it_on_its_line(self) -> None:
        values = {"vacuum": {"schedule": {"mon": "9am"}, "timezone": "Mars/Olympus"}}
        where = {("vacuum", "schedule"): 7, ("vacuum", "timezone"): 8}
        problems = schedule_problems(values, "robotd.toml", where)
        assert [(p.line, p.key) for p in problems] == [(8, "vacuum.timezone"),
                                                       (7, "vacuum.schedule")]

    def test_standby_waits_for_the_scheduled_start(self) -> None:
        rig = Rig("docking.standby")
        values = defaults()
        values["vacuum"].update(schedule={"thu": "00:05"}, timezone="UTC")
        rig.ctx.settings = Settings(values)

        async def main() -> float:
            begun = asyncio.get_running_loop().time()
            await VacuumProfile()._next_clean(rig.ctx)
            return asyncio.get_running_loop().time() - begun

        rig.ctx.wall_clock = lambda: THURSDAY + timedelta(minutes=1)
        waited = vclock.run(main())
        assert waited == pytest.approx(240.0)
        assert rig.events[-1][1]["by"] == "schedule"


class TestVirtualWall:
    def _coverage(self, rig: Rig) -> Coverage:
        return Coverage(rig.mover(), rig.bumpers, None, random.Random(1),  # type: ignore[arg-type]
                        rig.ir)

    def test_seen_ahead_it_turns_away(self) -> None:
        rig = Rig("mission.cleaning")
        rig.ir.see(omni=("virtual_wall",))

        async def main() -> int:
            rig.wheels.start_plant()
            coverage = self._coverage(rig)
            seen = coverage._virtual_wall()
            assert coverage._heed_virtual_wall(seen)
            await coverage.turn_away(rig.ctx, seen)
            return coverage.virtual_walls

        assert vclock.run(main()) == 1
        kind, fields = rig.events[-1]
        assert kind == "clean.virtual_wall" and 100 <= abs(fields["turn_deg"]) <= 200
        assert abs(rig.odometry.pose().theta_rad) > 1.0

    def test_seen_only_behind_it_drives_on(self) -> None:
        rig = Rig("mission.cleaning")
        rig.ir.see(rear=("virtual_wall",))

        async def main() -> bool:
            coverage = self._coverage(rig)
            return coverage._heed_virtual_wall(coverage._virtual_wall())

        assert vclock.run(main()) is False

    def test_while_leaving_the_beam_it_does_not_turn_again(self) -> None:
        rig = Rig("mission.cleaning")
        rig.ir.see(omni=("virtual_wall",))

        async def main() -> tuple[bool, bool]:
            rig.wheels.start_plant()
            coverage = self._coverage(rig)
            seen = coverage._virtual_wall()
            await coverage.turn_away(rig.ctx, seen)
            again = coverage._heed_virtual_wall(seen)
            await rig.mover().straight(0.6, 0.2)
            return again, coverage._heed_virtual_wall(seen)

        assert vclock.run(main()) == (False, True)
