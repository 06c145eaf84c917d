"""Property tests: random sequences of customer, admin and robot calls (a hypothesis state
machine) keep the seed's invariants, and every request ends once robots keep reporting."""

from __future__ import annotations

import asyncio
import tempfile
from pathlib import Path
from typing import Any

from fleet_harness import BASE_MAC, ROOM_MACS, Fleet, beacon
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, invariant, rule

from fleet.status import ROBOT_SERVING, TERMINAL, Action, Status

ROBOTS = ("robot-1", "robot-2")
STATUSES = {str(s) for s in Status}
PLACES = {"nowhere": [], "base": [BASE_MAC], "room1": [ROOM_MACS[1]], "room3": [ROOM_MACS[3]]}


class FleetMachine(RuleBasedStateMachine):
    """Customers, admins and robots calling the fleet server in any order."""

    def __init__(self) -> None:
        super().__init__()
        self.loop = asyncio.new_event_loop()
        self.dir = tempfile.TemporaryDirectory(prefix="fleet-props-")
        self.fleet = Fleet(f"sqlite:///{Path(self.dir.name) / 'fleet.db'}")
        self.run(self.fleet.__aenter__())
        self.request_ids: list[int] = []

    def run(self, coro: Any) -> Any:
        return self.loop.run_until_complete(coro)

    @rule(customer=st.integers(1, 5))
    def create(self, customer: int) -> None:
        response = self.run(self.fleet.create(customer))
        assert response.status_code in (201, 409, 503), response.text
        if response.status_code == 201:
            self.request_ids.append(response.json()["Id"])

    @rule(index=st.integers(0, 30), action=st.sampled_from(list(Action)))
    def act(self, index: int, action: Action) -> None:
        if not self.request_ids:
            return
        request_id = self.request_ids[index % len(self.request_ids)]
        response = self.run(self.fleet.act(request_id, str(action)))
        assert response.status_code in (200, 409, 503), response.text
        assert response.json()

    @rule(robot=st.sampled_from(ROBOTS), place=st.sampled_from(sorted(PLACES)),
          rssi=st.sampled_from([-40, -80]), in_target=st.booleans(),
          weight=st.sampled_from([0.0, 0.3, 3.0, 12.0, None]))
    def report(self, robot: str, place: str, rssi: int, in_target: bool,
               weight: float | None) -> None:
        beacons = [beacon(mac, rssi) for mac in PLACES[place]]
        self.run(self.fleet.exchange(robot, beacons=beacons, in_target=in_target,
                                     weight_kg=weight))

    @rule(robot=st.sampled_from(ROBOTS))
    def honest_report(self, robot: str) -> None:
        self.run(honest_report(self.fleet, robot))

    @rule(seconds=st.sampled_from([5.0, 31.0, 120.0, 400.0]))
    def time_passes(self, seconds: float) -> None:
        self.fleet.clock.advance(seconds)
        self.run(self.fleet.server.check_timeouts())
        self.run(self.fleet.server.check_offline())

    @rule(auto_accept=st.booleans(), preempt=st.booleans())
    def change_settings(self, auto_accept: bool, preempt: bool) -> None:
        self.run(self.fleet.settings(AutoAccept=auto_accept, PreemptBusyRobot=preempt))

    @rule(robot=st.sampled_from(ROBOTS), flag=st.sampled_from(
        ["IsActive", "EmergencyStop", "MaintenanceMode"]), value=st.booleans())
    def admin_flags(self, robot: str, flag: str, value: bool) -> None:
        response = self.run(self.fleet.http.patch(f"/api/robots/{robot}", json={flag: value}))
        assert response.status_code == 200

    @invariant()
    def statuses_are_the_seeds_and_robots_serve_one_request_each(self) -> None:
        self.run(check_invariants(self.fleet))

    def teardown(self) -> None:
        try:
            self.run(drain(self.fleet))
        finally:
            self.run(self.fleet.__aexit__(None, None, None))
            self.loop.close()
            self.dir.cleanup()


async def check_invariants(fleet: Fleet) -> None:
    requests = (await fleet.http.get("/api/requests", params={"limit": 1000})).json()
    robots = await fleet.robots()
    assert {r["Status"] for r in requests} <= STATUSES
    serving: dict[str, list[int]] = {}
    for request in requests:
        if request["Status"] in ROBOT_SERVING:
            serving.setdefault(request["AssignedRobotName"], []).append(request["Id"])
    for name, ids in serving.items():
        assert len(ids) == 1, f"{name} serves {ids}"
        assert robots[name]["CurrentRequestId"] == ids[0]
    current = [r["CurrentRequestId"] for r in robots.values() if r["CurrentRequestId"]]
    assert len(current) == len(set(current))
    by_id = {r["Id"]: r for r in requests}
    for request_id in current:
        assert by_id[request_id]["Status"] in ROBOT_SERVING | {"Cancelled"}


async def honest_report(fleet: Fleet, robot: str) -> None:
    """A robot that goes where it is told and reports arrival truthfully; customers load
    and unload when it waits at their room."""
    robots = await fleet.robots()
    current = robots[robot]["CurrentRequestId"]
    status = (await fleet.get(current))["Status"] if current else None
    weight = {"ArrivedAtRoom": 3.0, "FinishedWashingArrivedAtRoom": 0.0}.get(status or "", 0.0)
    reply = await fleet.exchange(robot, weight_kg=weight)
    targets = [b["MacAddress"] for b in reply["ActiveBeacons"] if b["IsNavigationTarget"]]
    if targets:
        await fleet.exchange(robot, beacons=[beacon(targets[0], -40)], in_target=True,
                             weight_kg=weight)


async def drain(fleet: Fleet, rounds: int = 60) -> None:
    """Robots keep reporting, customers and the admin do their part, time passes: every
    request must reach a terminal status."""
    for robot in ROBOTS:
        await fleet.http.patch(f"/api/robots/{robot}", json={
            "IsActive": True, "EmergencyStop": False, "MaintenanceMode": False})
    for _ in range(rounds):
        requests = (await fleet.http.get("/api/requests", params={"limit": 1000})).json()
        open_requests = [r for r in requests if r["Status"] not in TERMINAL]
        if not open_requests:
            return
        for request in open_requests:
            action = {
                "Pending": "accept" if not request["IsApproved"] else None,
                "ArrivedAtRoom": "confirm-loaded" if request["CanConfirmLoaded"] else None,
                "Washing": "washing-done",
                "FinishedWashingArrivedAtRoom": (
                    "confirm-unloaded" if request["CanConfirmUnloaded"] else None),
            }.get(request["Status"])
            if action is not None:
                await fleet.act(request["Id"], action)
        fleet.clock.advance(60)
        for robot in ROBOTS:
            await honest_report(fleet, robot)
        await fleet.server.check_timeouts()
        await fleet.server.check_offline()
    left = [(r["Id"], r["Status"]) for r in
            (await fleet.http.get("/api/requests", params={"limit": 1000})).json()
            if r["Status"] not in TERMINAL]
    raise AssertionError(f"requests still open after {rounds} rounds: {left}")


FleetMachine.TestCase.settings = settings(
    max_examples=12, stateful_step_count=25, deadline=None,
    suppress_health_check=[HealthCheck.too_slow])
TestFleetStateMachine = FleetMachine.TestCase
