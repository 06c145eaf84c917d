"""Every robot's site status report (issue 29), robot side: the body it sends each period, the
staff's orders it takes from the answer, and a server that is away."""

from __future__ import annotations

import asyncio
import json
from collections.abc import Awaitable, Callable
from typing import Any

import httpx

from behaviours.context import Fault, RobotContext
from behaviours.machine import RobotMachine
from behaviours.profile import BaseProfile, SiteFacts
from behaviours.site_report.orders import StaffOrders
from behaviours.site_report.reporter import SiteReporter, parse_answer
from behaviours.site_report.status import site_fields, status_body
from hal.backend import Devices
from hal.ports import system_wall_clock
from robotd.config import Settings
from robotd.config.loader import defaults
from sim import vclock


class DictStore(dict[str, Any]):
    def put(self, key: str, value: Any) -> None:
        self[key] = value

    def delete(self, key: str) -> None:
        self.pop(key, None)


class Worker(BaseProfile):
    name = "worker"

    def mission_states(self) -> list[str | dict[str, Any]]:
        return ["work"]

    def site_facts(self, ctx: RobotContext) -> SiteFacts:
        return SiteFacts(x_m=1.23456, y_m=-2.0, theta_rad=0.5, map_name="depot", job="order 7")


class Server:
    """The fleet server's status endpoint, as a transport: records bodies, answers orders."""

    def __init__(self) -> None:
        self.bodies: list[dict[str, Any]] = []
        self.headers: list[httpx.Headers] = []
        self.orders = {"EmergencyStop": False, "MaintenanceMode": False}
        self.down = False
        self.answer: Any = None

    def handle(self, request: httpx.Request) -> httpx.Response:
        if self.down:
            msg = "connection refused"
            raise httpx.ConnectError(msg, request=request)
        assert request.url.path == "/api/Robot/bot-1/status"
        self.bodies.append(json.loads(request.content))
        self.headers.append(request.headers)
        return httpx.Response(200, json=self.answer if self.answer is not None else self.orders)


Scenario = Callable[["Rig"], Awaitable[None]]


class Rig:
    def __init__(self) -> None:
        settings = Settings(defaults())
        settings.set("robot.name", "bot-1")
        self.ctx = RobotContext(Devices(), settings, DictStore(), system_wall_clock,
                                lambda kind, **f: None)
        self.profile = Worker()
        self.machine = RobotMachine(self.profile, self.ctx, on_transition=lambda *a: None,
                                    stop_motors=self._stop)
        self.server = Server()
        client = httpx.AsyncClient(transport=httpx.MockTransport(self.server.handle),
                                   base_url="http://fleet.test")
        self.estops: list[tuple[str, str]] = []
        self.reporter = SiteReporter(
            client, "bot-1", lambda: status_body(self.ctx, "worker",
                                                 self.profile.site_facts(self.ctx)),
            StaffOrders(self.ctx, self._estop), period_s=lambda: 1.0, token="tok-123")

    async def _stop(self) -> None:
        pass

    async def _estop(self, reason: str, source: str) -> bool:
        self.estops.append((reason, source))
        return await self.machine.trigger("estop", reason=reason, source=source)

    def run(self, scenario: Scenario) -> None:
        async def main() -> None:
            machine = asyncio.create_task(self.machine.run(lambda: None))
            await asyncio.sleep(0)
            await self.machine.trigger("booted")
            await self.machine.trigger("start_mission")
            reporting = asyncio.create_task(self.reporter.run(lambda: None))
            try:
                await scenario(self)
            finally:
                for task in (reporting, machine):
                    task.cancel()
                await asyncio.gather(reporting, machine, return_exceptions=True)

        vclock.run(main())


class TestTheReport:
    def test_every_period_it_says_what_the_robot_is_doing(self) -> None:
        """One report a second, on the loop's clock, with the robot's token."""
        rig = Rig()

        async def scenario(r: Rig) -> None:
            await asyncio.sleep(4.5)

        rig.run(scenario)
        assert len(rig.server.bodies) == 5
        body = rig.server.bodies[-1]
        assert {k: body[k] for k in ("RobotName", "Profile", "State", "EmergencyStopActive",
                                     "Fault", "BatteryPct", "Place", "Job")} == {
            "RobotName": "bot-1", "Profile": "worker", "State": "mission.work",
            "EmergencyStopActive": False, "Fault": None, "BatteryPct": None, "Place": None,
            "Job": "order 7"}
        assert body["Pose"] == {"X": 1.235, "Y": -2.0, "Theta": 0.5, "Map": "depot"}
        assert body["Timestamp"].endswith("Z")
        assert rig.server.headers[0]["Authorization"] == "Bearer tok-123"

    def test_the_machines_fault_comes_before_the_profiles_own(self) -> None:
        rig = Rig()

        async def scenario(r: Rig) -> None:
            facts = SiteFacts(fault=Fault("stuck", "error recovery: stuck"))
            assert status_body(r.ctx, "worker", facts)["Fault"] == {
                "Code": "stuck", "Message": "error recovery: stuck"}
            await r.ctx.trigger("fault", code="line_lost", reason="no line")
            assert status_body(r.ctx, "worker", facts)["Fault"] == {
                "Code": "line_lost", "Message": "no line"}

        rig.run(scenario)


    def test_a_robot_on_a_line_gives_its_place_and_long_text_is_cut(self) -> None:
        """What the laundry data exchange adds too: no pose, the last room; text longer than
        the server's columns is cut rather than refused."""
        fields = site_fields("laundry", SiteFacts(place="Room 101", job="x" * 300))
        assert (fields["Profile"], fields["Pose"], fields["Place"]) == (
            "laundry", None, "Room 101")
        assert len(fields["Job"]) == 200


class TestServerAway:
    def test_failures_are_counted_and_retried_each_period_without_stopping(self) -> None:
        rig = Rig()

        async def scenario(r: Rig) -> None:
            r.server.down = True
            await asyncio.sleep(3.5)
            assert r.reporter.counts["failed"] == 4
            assert r.reporter.last_error is not None
            assert "ConnectError" in r.reporter.last_error
            assert r.ctx.state == "mission.work"  # the robot goes on
            r.server.down = False
            await asyncio.sleep(1.0)
            assert r.reporter.last_error is None

        rig.run(scenario)
        assert rig.reporter.counts["ok"] == 1

    def test_a_bad_answer_is_a_failure_and_orders_nothing(self) -> None:
        rig = Rig()

        async def scenario(r: Rig) -> None:
            r.server.answer = {"EmergencyStop": "yes", "MaintenanceMode": False}
            await asyncio.sleep(1.5)

        rig.run(scenario)
        assert rig.reporter.counts["failed"] == 2
        assert rig.ctx.state == "mission.work" and rig.estops == []

    def test_parse_answer_wants_both_flags(self) -> None:
        assert parse_answer({"EmergencyStop": True, "MaintenanceMode": False}) == (True, False)
        for bad in ([], {"EmergencyStop": True}, {"EmergencyStop": 1, "MaintenanceMode": 0}):
            try:
                parse_answer(bad)
            except ValueError:
                continue
            raise AssertionError(bad)


class TestStaffOrders:
    def test_estop_takes_the_robots_estop_and_resume_lets_it_go_on(self) -> None:
        rig = Rig()

        async def scenario(r: Rig) -> None:
            await asyncio.sleep(0.5)
            r.server.orders["EmergencyStop"] = True
            await asyncio.sleep(1.0)
            assert r.ctx.state == "estop"
            assert r.estops == [("the fleet server's EmergencyStop", "fleet")]
            assert r.ctx.estop_latch.only_from("fleet")
            r.server.orders["EmergencyStop"] = False
            await asyncio.sleep(1.0)
            assert r.ctx.state == "mission.work"  # resumed, and back to its mission
            assert not r.ctx.estop_latch.latched

        rig.run(scenario)

    def test_an_estop_a_person_latched_is_not_the_servers_to_lift(self) -> None:
        rig = Rig()

        async def scenario(r: Rig) -> None:
            await r.machine.trigger("estop", reason="robotctl estop", source="robotctl")
            r.server.orders["EmergencyStop"] = True
            await asyncio.sleep(1.5)
            r.server.orders["EmergencyStop"] = False
            await asyncio.sleep(2.0)
            assert r.ctx.state == "estop" and r.ctx.estop_latch.latched
            assert r.estops == []  # already stopped: the server's order changed nothing

        rig.run(scenario)

    def test_maintenance_holds_it_stopped_until_lifted(self) -> None:
        rig = Rig()

        async def scenario(r: Rig) -> None:
            r.server.orders["MaintenanceMode"] = True
            await asyncio.sleep(1.5)
            assert r.ctx.state == "maintenance"
            r.server.orders["MaintenanceMode"] = False
            await asyncio.sleep(1.0)
            assert r.ctx.state == "idle"

        rig.run(scenario)
