"""The navigator: directives become mission states; the server's estop is lifted only by it."""

from __future__ import annotations

import asyncio
from datetime import UTC, datetime
from typing import Any

from behaviours.beacons.arrival import Arrival
from behaviours.beacons.tracker import BeaconTracker
from behaviours.context import RobotContext
from behaviours.profiles.laundry.directive import Directive
from behaviours.profiles.laundry.navigator import Navigator
from hal.backend import Devices
from hal.readings import BeaconSighting
from robotd.config.loader import defaults
from robotd.config.settings import Settings
from sim import vclock

# The laundry profile's transitions and the core ones it relies on, as (state, trigger) -> dest.
TABLE = {
    ("idle", "go_room"): "mission.to_room", ("idle", "go_base"): "mission.to_base",
    ("mission.at_room", "go_base"): "mission.to_base",
    ("mission.to_room", "go_base"): "mission.to_base",
    ("mission.to_room", "arrived_room"): "mission.at_room",
    ("mission.to_base", "arrived_base"): "mission.at_base",
    ("mission.to_room", "mission_done"): "idle", ("mission.at_room", "mission_done"): "idle",
    ("mission.to_base", "mission_done"): "idle", ("mission.at_base", "mission_done"): "idle",
    ("recovery", "recovered"): "idle", ("estop", "resume"): "idle",
    ("maintenance", "end_maintenance"): "idle",
}


class TableMachine:
    """A state machine over TABLE (estop/maintenance from anywhere), recording triggers."""

    def __init__(self, state: str = "idle") -> None:
        self.state = state
        self.fired: list[str] = []

    async def trigger(self, name: str, **_kw: Any) -> bool:
        dest = {"estop": "estop", "maintenance": "maintenance", "fault": "recovery"}.get(name) \
            or TABLE.get((self.state, name))
        if dest is None:
            return False
        self.fired.append(name)
        self.state = dest
        return True


class QueuedMachine(TableMachine):
    """Like the daemon's machine: triggers wait in one queue a task works through, so the
    state a behaviour reads may be about to change. Refused triggers are recorded."""

    def __init__(self, state: str = "idle") -> None:
        super().__init__(state)
        self.refused: list[tuple[str, str]] = []
        self._lock = asyncio.Lock()

    async def trigger(self, name: str, **kw: Any) -> bool:
        async with self._lock:
            await asyncio.sleep(0.01)  # the transition's callbacks
            before = self.state
            done = await super().trigger(name, **kw)
            if not done:
                self.refused.append((before, name))
            return done


class _Store:
    def get(self, key: str, default: Any = None) -> Any:
        return default

    def put(self, key: str, value: Any) -> None: ...

    def delete(self, key: str) -> None: ...


def _rig(state: str = "idle", machine: TableMachine | None = None, enter_hold_s: float = 0.0
         ) -> tuple[Navigator, TableMachine, BeaconTracker, list[str]]:
    colours: list[str] = []
    ctx = RobotContext(Devices(), Settings(defaults()), _Store(),
                       lambda: datetime(2026, 1, 1, tzinfo=UTC), lambda *_a, **_k: None)
    machine = machine or TableMachine(state)
    ctx.attach(machine)
    tracker = BeaconTracker(smoothing_s=0)
    arrival = Arrival(tracker, enter_hold_s=enter_hold_s)  # 0: one sighting is an arrival
    nav = Navigator(ctx, tracker, arrival, lambda c: colours.append(str(c)))
    return nav, machine, tracker, colours


def _to(room: str, *, follow: bool = True, **flags: bool) -> Directive:
    mac = "AA:00:00:00:00:01" if room == "base" else "AA:00:00:00:01:01"
    beacons = ({"MacAddress": mac, "Name": room, "RoomName": room, "RssiThreshold": -60,
                "IsNavigationTarget": True},)
    return Directive(line_following=follow, active_beacons=beacons, **flags)


def _sight(tracker: BeaconTracker, mac: str, rssi: int) -> None:
    tracker.add_sighting(BeaconSighting(mac, "u", 1, 1, rssi, -59,
                                        asyncio.get_running_loop().time()))


class TestNavigator:
    def test_follows_to_the_target_room_and_stops_there_by_itself(self) -> None:
        """Going, then the room's beacon crosses its threshold: at_room without the server."""

        async def main() -> list[str]:
            nav, machine, tracker, _ = _rig()
            await nav.apply(_to("101"))
            assert machine.state == "mission.to_room"
            _sight(tracker, "AA:00:00:00:01:01", -50)
            nav.arrival.update()
            await asyncio.sleep(0)  # the arrival trigger runs as a task
            await nav.apply(_to("101"))  # the server has not caught up: nothing changes
            await nav.apply(_to("101", follow=False))
            return [machine.state, *machine.fired]

        assert vclock.run(main()) == ["mission.at_room", "go_room", "arrived_room"]

    def test_base_target_goes_to_base_and_idles_once_the_server_is_done(self) -> None:
        async def main() -> list[str]:
            nav, machine, tracker, _ = _rig("mission.at_room")
            nav.arrived_room = "101"
            await nav.apply(_to("base"))
            _sight(tracker, "AA:00:00:00:00:01", -50)
            nav.arrival.update()
            await asyncio.sleep(0)
            await nav.apply(Directive.stand_still())
            return machine.fired

        assert vclock.run(main()) == ["go_base", "arrived_base", "mission_done"]

    def test_told_to_stop_before_arriving_means_idle(self) -> None:
        async def main() -> str:
            nav, machine, _, _ = _rig()
            await nav.apply(_to("101"))
            await nav.apply(Directive.stand_still())
            return machine.state

        assert vclock.run(main()) == "idle"

    def test_the_server_lifts_its_own_estop_but_not_a_technicians(self) -> None:
        async def main() -> list[str]:
            nav, machine, _, _ = _rig()
            await nav.apply(_to("101", emergency_stop=True))
            assert machine.state == "estop"
            await nav.apply(_to("101"))  # lifted: resume, then carry on
            after_server = machine.state
            await machine.trigger("estop")  # robotctl estop
            await nav.apply(_to("101"))
            return [after_server, machine.state]

        assert vclock.run(main()) == ["idle", "estop"]

    def test_maintenance_mode_holds_the_robot_until_lifted(self) -> None:
        async def main() -> list[str]:
            nav, machine, _, _ = _rig()
            await nav.apply(_to("101", maintenance=True))
            held = machine.state
            await nav.apply(_to("101"))
            return [held, machine.state]

        assert vclock.run(main()) == ["maintenance", "idle"]

    def test_a_lost_line_is_retried_twice_then_the_robot_stays_stopped(self) -> None:
        async def main() -> list[str]:
            nav, machine, _, _ = _rig()
            states = []
            for _ in range(4):
                await nav.apply(_to("101"))
                await machine.trigger("fault")
                nav.line_lost()
                await asyncio.sleep(6)
                await nav.apply(_to("101"))
                states.append(machine.state)
            return states

        assert vclock.run(main()) == ["mission.to_room", "mission.to_room", "recovery",
                                      "recovery"]

    def test_passes_the_follow_colour_on(self) -> None:
        async def main() -> list[str]:
            nav, _, _, colours = _rig()
            await nav.apply(Directive(line_following=True, follow_color="blue"))
            return colours

        assert vclock.run(main()) == ["blue"]

    def test_an_arrival_seen_as_the_server_changes_the_leg_is_not_taken_for_the_old_leg(
            self) -> None:
        """On its way to a room, still beside the base, the robot is sent back to base (the
        request was cancelled): the base beacon becomes the target and is already strong. The
        machine must get go_base, not an arrived_room it would refuse from to_base, and then
        arrived_base, as the robot is at base."""

        async def main() -> tuple[list[str], list[tuple[str, str]], str]:
            machine = QueuedMachine()
            nav, _, tracker, _ = _rig(machine=machine)
            await nav.apply(_to("101"))
            _sight(tracker, "AA:00:00:00:00:01", -50)  # the base beacon, right beside it
            await nav.apply(_to("base"))
            await asyncio.sleep(1)
            return machine.fired, machine.refused, machine.state

        fired, refused, state = vclock.run(main())
        assert refused == []
        assert fired == ["go_room", "go_base", "arrived_base"]
        assert state == "mission.at_base"


    def test_sent_back_to_base_beside_it_arrives_once_the_entry_hold_has_passed(self) -> None:
        """With the entry hold (0.5 s of sightings): sent back to base while beside its
        beacon, the robot arrives once the beacon has held its level that long - not at
        once, and not never."""

        async def main() -> tuple[list[str], list[str], str]:
            machine = QueuedMachine()
            nav, _, tracker, _ = _rig(machine=machine, enter_hold_s=0.5)
            await nav.apply(_to("101"))

            async def advertise() -> None:  # the base beacon beside it, 10 adverts a second
                while True:
                    _sight(tracker, "AA:00:00:00:00:01", -50)
                    await asyncio.sleep(0.1)

            tasks = [asyncio.create_task(advertise()), asyncio.create_task(nav.arrival.run())]
            await asyncio.sleep(0.05)
            await nav.apply(_to("base"))
            await asyncio.sleep(0.3)
            early = list(machine.fired)
            await asyncio.sleep(0.5)
            for task in tasks:
                task.cancel()
            return early, machine.fired, machine.state

        early, fired, state = vclock.run(main())
        assert early == ["go_room", "go_base"]
        assert fired == ["go_room", "go_base", "arrived_base"]
        assert state == "mission.at_base"
