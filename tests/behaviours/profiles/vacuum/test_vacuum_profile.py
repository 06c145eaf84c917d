"""The vacuum profile: the seed's periodic battery check, its states, its registry entry."""

from __future__ import annotations

import asyncio
import random

import pytest
from docking_doubles import Rig

from behaviours.profiles.vacuum.cleaning import Coverage
from behaviours.profiles.vacuum.profile import VacuumProfile
from hal.readings import BatteryReading, Bumpers
from robotd.profiles import PROFILES
from sim import vclock


class TestBatteryCheck:
    @pytest.mark.parametrize(("pct", "trigger"), [
        (19.9, "go_dock"), (20.0, "battery_ok"), (85.0, "battery_ok")])
    def test_below_the_threshold_the_check_sends_it_to_the_dock(self, pct: float,
                                                                 trigger: str) -> None:
        """docking.battery_threshold_pct (20 %): below it go_dock, else clean on."""
        rig = Rig("mission.battery_check")
        rig.battery.value = BatteryReading(11.0, pct, False, False, 0.0)
        vclock.run(VacuumProfile()._battery_check(rig.ctx))
        assert rig.machine.names == [trigger]

    def test_the_check_comes_round_every_battery_check_s(self) -> None:
        rig = Rig("mission.cleaning")

        async def main() -> float:
            await VacuumProfile()._battery_timer(rig.ctx)
            return asyncio.get_running_loop().time()

        assert vclock.run(main()) == pytest.approx(rig.settings.get("vacuum.battery_check_s"))
        assert rig.machine.names == ["check_battery"]


class TestProfile:
    def test_the_seed_states_and_the_registry(self) -> None:
        profile = VacuumProfile()
        assert profile.mission_states() == ["cleaning", "battery_check"]
        assert PROFILES.get("vacuum").profile is VacuumProfile
        tasks = profile.state_tasks()
        assert {"mission", "mission.battery_check", "docking", "docking.search",
                "docking.align", "docking.emptying"} <= set(tasks)


class TestCoverage:
    def test_a_bump_backs_off_and_turns_away(self) -> None:
        """Bouncing: pressed bumpers -> back off, then a turn of 100-200 degrees."""
        rig = Rig("mission.cleaning")
        rig.bumpers.value = Bumpers(True, False, 0.0)

        async def main() -> tuple[int, float]:
            rig.wheels.start_plant()
            coverage = Coverage(rig.mover(), rig.bumpers, None,  # type: ignore[arg-type]
                                random.Random(1))
            await coverage.bounce(rig.ctx)
            return coverage.bounces, rig.odometry.pose().theta_rad

        bounces, heading = vclock.run(main())
        assert bounces == 1
        assert abs(heading) > 1.0  # turned away (wrapped: 100-200 deg either way round)
        assert rig.events[-1][0] == "clean.bounce"
