"""The data exchange carries the robot's own state (issue 27): State, EmergencyStopActive, Fault
and BatteryPct are stored, shown in GET /api/robots, and acted on; bad values are 422."""

from __future__ import annotations

from typing import Any

import pytest
from fleet_harness import Fleet


async def report(fleet: Fleet, robot: str = "robot-1", **state: Any) -> dict[str, Any]:
    response = await fleet.http.post(f"/api/Robot/{robot}/data-exchange", json={
        "RobotName": robot, "IsInTarget": False, "WeightKg": 0.0, **state})
    assert response.status_code == 200, response.text
    body: dict[str, Any] = response.json()
    return body


class TestStored:
    async def test_the_reported_state_is_shown_in_the_robot_list(self, fleet):
        """What the robot says of itself is what GET /api/robots shows."""
        await report(fleet, State="mission.to_room", EmergencyStopActive=False,
                     Fault=None, BatteryPct=87.5)
        robot = (await fleet.robots())["robot-1"]
        assert (robot["State"], robot["EmergencyStopActive"], robot["Fault"],
                robot["BatteryPct"]) == ("mission.to_room", False, None, 87.5)
        await report(fleet, State="recovery", EmergencyStopActive=False, BatteryPct=80,
                     Fault={"Code": "line_lost", "Message": "no line for 3 s"})
        robot = (await fleet.robots())["robot-1"]
        assert robot["State"] == "recovery"
        assert robot["Fault"] == {"Code": "line_lost", "Message": "no line for 3 s"}
        assert robot["BatteryPct"] == 80

    async def test_an_older_robot_that_sends_none_of_them_shows_nulls(self, fleet):
        robot = (await fleet.robots())["robot-1"]
        assert (robot["State"], robot["EmergencyStopActive"], robot["Fault"],
                robot["BatteryPct"]) == (None, None, None, None)

    async def test_quiet_reports_need_no_write_transaction(self, fleet):
        """A report whose e-stop and fault code are unchanged is answered without a
        serialized write, even when its state path, battery or fault text changed: those
        ride with the batched pings."""
        fault = {"Code": "blocked", "Message": "obstacle for 10 s"}
        await report(fleet, State="mission.to_room", EmergencyStopActive=False, Fault=fault,
                     BatteryPct=90.0)
        writes = fleet.server.db.generation
        for second in range(11, 15):
            await report(fleet, State="mission.to_room", EmergencyStopActive=False,
                         Fault={"Code": "blocked", "Message": f"obstacle for {second} s"},
                         BatteryPct=90.0 - second / 10)
        await report(fleet, State="mission.at_room", EmergencyStopActive=False, Fault=fault,
                     BatteryPct=88.0)
        assert fleet.server.db.generation == writes
        robot = (await fleet.robots())["robot-1"]
        assert (robot["State"], robot["BatteryPct"]) == ("mission.at_room", 88.0)
        assert robot["Fault"] == fault


class TestEmergencyStop:
    async def test_a_robot_in_its_own_estop_shows_it_and_is_not_assigned(self, fleet):
        """EmergencyStopActive shows as status EmergencyStop; the robot serves nobody until
        its latch is released, then it serves the queue."""
        await report(fleet, "robot-1", EmergencyStopActive=True)
        await report(fleet, "robot-2", EmergencyStopActive=True)
        robots = await fleet.robots()
        assert robots["robot-1"]["Status"] == "EmergencyStop"
        assert robots["robot-1"]["EmergencyStopActive"] is True
        assert robots["robot-1"]["EmergencyStop"] is False  # the server's order is apart
        assert (await fleet.create(1)).status_code == 503
        await report(fleet, "robot-2", EmergencyStopActive=False)
        first = await fleet.request(1)
        assert first["AssignedRobotName"] == "robot-2"
        second = await fleet.request(2)
        assert second["Status"] == "Pending"
        await report(fleet, "robot-1", EmergencyStopActive=False)
        body = await fleet.get(second["Id"])
        assert (body["Status"], body["AssignedRobotName"]) == ("Accepted", "robot-1")
        kinds = [n["Kind"] for n in await fleet.notifications(recipient="admin")]
        assert kinds.count("robot.estop") == 2


LONG = "x" * 101


class TestBadValues:
    @pytest.mark.parametrize(("field", "value"), [
        ("State", LONG), ("State", ""), ("State", 3), ("State", "a\nb"),
        ("EmergencyStopActive", "yes"), ("EmergencyStopActive", 1),
        ("Fault", "line_lost"), ("Fault", {"Message": "no code"}), ("Fault", {"Code": ""}),
        ("Fault", {"Code": "c" * 61}), ("Fault", {"Code": "x", "Message": "m" * 501}),
        ("Fault", {"Code": 7}), ("BatteryPct", 100.5), ("BatteryPct", -1),
        ("BatteryPct", "80"), ("BatteryPct", True),
    ])
    async def test_a_bad_value_is_422_naming_the_field(self, fleet, field, value):
        """Through the fast path and the route alike: 422 with the field in the message,
        never 500, and nothing stored."""
        response = await fleet.http.post("/api/Robot/robot-1/data-exchange",
                                          json={"RobotName": "robot-1", field: value})
        assert response.status_code == 422, response.text
        body = response.json()
        assert field in body["detail"]
        assert any(field in error["loc"] for error in body["errors"])

    async def test_bounds_are_accepted(self, fleet):
        await report(fleet, State="s" * 100, BatteryPct=0, Fault={"Code": "c" * 60,
                                                                   "Message": "m" * 500})
        await report(fleet, BatteryPct=100)
        robot = (await fleet.robots())["robot-1"]
        assert robot["BatteryPct"] == 100
