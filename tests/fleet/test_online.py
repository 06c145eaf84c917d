"""Online means reported (issue 27): a robot is assignable only after its first data exchange
and while its last one is younger than OfflineAfterS."""

from __future__ import annotations

from collections.abc import AsyncIterator

import pytest
from fleet_harness import Fleet


@pytest.fixture
async def unheard(db_url: str) -> AsyncIterator[Fleet]:
    """The test site with robots registered but never heard from."""
    async with Fleet(db_url, report=False) as fleet:
        yield fleet


class TestNeverReported:
    async def test_a_registered_robot_is_offline_until_it_reports(self, unheard):
        """The site file registers the robots; until they report they show Offline."""
        robots = await unheard.robots()
        assert {r["Status"] for r in robots.values()} == {"Offline"}
        assert {r["LastPingAt"] for r in robots.values()} == {None}
        await unheard.exchange("robot-1")
        robots = await unheard.robots()
        assert (robots["robot-1"]["Status"], robots["robot-2"]["Status"]) == (
            "Available", "Offline")

    async def test_no_robot_ever_heard_from_is_503(self, unheard):
        """With no robot that has reported, no robot can serve: 503, nothing stored."""
        response = await unheard.create(1)
        assert response.status_code == 503
        assert "no robot" in response.json()["detail"]
        assert (await unheard.http.get("/api/requests")).json() == []

    async def test_a_never_reporting_robot_is_not_assigned(self, unheard):
        """robot-1 (first by id) never reported: the request goes to robot-2, which did; the
        next one waits Pending with no robot named, and is dispatched to robot-1 at its
        first data exchange."""
        await unheard.exchange("robot-2")
        first = await unheard.request(1)
        assert (first["Status"], first["AssignedRobotName"]) == ("Accepted", "robot-2")
        second = await unheard.request(2)
        assert second["Status"] == "Pending"
        assert second["AssignedRobotName"] is None
        reply = await unheard.exchange("robot-1")
        assert reply["RequestId"] == second["Id"]
        body = await unheard.get(second["Id"])
        assert (body["Status"], body["AssignedRobotName"]) == ("Accepted", "robot-1")
        kinds = [n["Kind"] for n in await unheard.notifications(recipient="admin")]
        assert kinds.count("robot.online") == 2
        assert "robot.reconnected" not in kinds


class TestSilentRobots:
    async def test_a_robot_silent_past_the_limit_is_not_assigned(self, fleet):
        """Between two passes of the offline monitor a silent robot is not yet marked
        offline, but it is not sent to a customer either."""
        fleet.clock.advance(31)
        await fleet.exchange("robot-2")
        body = await fleet.request(1)
        assert body["AssignedRobotName"] == "robot-2"
        second = await fleet.request(2)
        assert second["Status"] == "Pending"
        assert second["AssignedRobotName"] is None
        await fleet.exchange("robot-1")
        assert (await fleet.get(second["Id"]))["AssignedRobotName"] == "robot-1"

    async def test_every_robot_silent_is_503(self, fleet):
        fleet.clock.advance(31)
        assert (await fleet.create(1)).status_code == 503
        await fleet.report_all()
        assert (await fleet.create(1)).status_code == 201
