"""Directives without a fleet server: rooms in turn, waiting for a load at customer rooms."""

from __future__ import annotations

import asyncio

from behaviours.profiles.laundry.directive import Directive
from behaviours.profiles.laundry.load_check import LoadCheck
from behaviours.profiles.laundry.local_route import LocalRoute
from hal.readings import WeightReading
from sim import vclock

BEACONS = {"AA:00:00:00:00:01": {"room": "base", "rssi_threshold_dbm": -60,
                                 "floor_color": "red"},
           "AA:00:00:00:01:03": {"room": "103", "rssi_threshold_dbm": -55}}


class TestLocalRoute:
    def test_targets_each_room_in_turn_with_the_room_floor_colour(self) -> None:
        async def main() -> list[tuple[bool, list[str], str | None]]:
            seen: list[Directive] = []

            async def take(d: Directive) -> None:
                seen.append(d)

            route = LocalRoute(["103", "base"], BEACONS, "base", None, take, period_s=1.0)
            task = asyncio.create_task(route.run())
            await asyncio.sleep(2.5)
            route.arrived("103")
            await asyncio.sleep(2.5)
            route.arrived("base")
            await asyncio.sleep(2.5)
            task.cancel()
            out = []
            for d in seen:
                item = (d.line_following, d.target_rooms(), d.follow_color)
                if not out or out[-1] != item:
                    out.append(item)
            return out

        assert vclock.run(main()) == [
            (True, ["103"], None), (False, ["103"], None),
            (True, ["base"], "red"), (False, ["base"], "red"),
            (False, [], None)]

    def test_waits_at_a_customer_room_until_a_stable_load(self) -> None:
        """Not before the load is in; soon after it has settled (LoadCheck's window)."""

        async def main() -> tuple[float, int]:
            loop = asyncio.get_running_loop()
            load = LoadCheck(min_kg=0.5, max_kg=10.0, stable_s=1.0)

            async def take(_d: Directive) -> None: ...

            route = LocalRoute(["103", "base"], BEACONS, "base", load, take, period_s=1.0)
            task = asyncio.create_task(route.run())
            await asyncio.sleep(0.5)
            route.arrived("103")
            for i in range(40):  # 4 s empty, then 4.2 kg
                load.add(WeightReading(0.0 if i < 20 else 4.2, 0, loop.time()))
                await asyncio.sleep(0.2)
                if route.leg == 1:
                    break
            task.cancel()
            return loop.time(), route.leg

        left_at, leg = vclock.run(main())
        assert leg == 1
        assert 4.5 + 1.0 <= left_at <= 4.5 + 5.0  # loaded at 4.5 s; needs 1 s of steady weight
