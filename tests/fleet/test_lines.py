"""Line traffic (issue 27): at most one robot travels a painted line that rooms share; a
request for a room on a line another robot is on waits Pending, and its robot is told why
(WaitingFor "line"). A site that declares no lines keeps the behaviour before them."""

from __future__ import annotations

from collections.abc import AsyncIterator

import pytest
from fleet_harness import (
    BASE_MAC,
    SITE_TOML,
    Fleet,
    alerts,
    beacon,
    loaded,
    offline,
    resolve,
    targets,
)

from fleet.site import SiteError, parse_site

# Rooms 101 and 102 (customers 1 and 2) share the painted line "east"; 201 and 202 do not.
EAST = """
[[lines]]
name = "east"
rooms = ["Room 101", "Room 102"]
"""


@pytest.fixture
async def lined(db_url: str) -> AsyncIterator[Fleet]:
    async with Fleet(db_url, site_toml=SITE_TOML + EAST) as fleet:
        yield fleet


async def back_at_base(fleet: Fleet, robot: str, request_id: int) -> None:
    customer = (await fleet.get(request_id))["CustomerId"]
    await fleet.arrive_at_room(robot, customer, weight_kg=3.0)
    await fleet.do(request_id, "confirm-loaded")
    await fleet.arrive_at_base(robot, weight_kg=3.0)
    await fleet.unloaded(robot)


class TestOneRobotOnALine:
    async def test_a_request_on_a_busy_line_waits_and_its_robot_is_told(self, lined):
        first = await lined.request(1)
        assert (first["Status"], first["AssignedRobotName"]) == ("Accepted", "robot-1")
        second = await lined.request(2)
        assert (second["Status"], second["AssignedRobotName"]) == ("Pending", "robot-2")
        reply = await lined.exchange("robot-2")
        assert (reply["WaitingFor"], reply["RequestId"], targets(reply)) == ("line", None, set())
        assert (await lined.robots())["robot-2"]["WaitingFor"] == "line"
        await back_at_base(lined, "robot-1", first["Id"])
        body = await lined.get(second["Id"])
        assert (body["Status"], body["AssignedRobotName"]) == ("Accepted", "robot-2")
        reply = await lined.exchange("robot-2")
        assert (reply["WaitingFor"], reply["RequestId"]) == (None, second["Id"])

    async def test_standing_at_the_room_and_the_way_back_count(self, lined):
        """The line is in use from dispatch until the robot is back at base, even for a
        cancelled request's robot on its way back."""
        first = await lined.request(1)
        second = await lined.request(2)
        await lined.arrive_at_room("robot-1", 1)
        assert await lined.status(second["Id"]) == "Pending"
        await lined.do(first["Id"], "cancel")
        assert await lined.status(second["Id"]) == "Pending"
        await lined.arrive_at_base("robot-1")
        assert await lined.status(second["Id"]) == "Accepted"

    async def test_a_room_on_no_shared_line_goes_meanwhile(self, lined):
        """The oldest request that can go goes: one for room 201 passes the waiting one."""
        await lined.request(1)
        waiting = await lined.request(2)
        other = await lined.request(3)
        assert (other["Status"], other["AssignedRobotName"]) == ("Accepted", "robot-2")
        assert await lined.status(waiting["Id"]) == "Pending"
        reply = await lined.exchange("robot-2")
        assert reply["WaitingFor"] is None

    async def test_delivery_on_a_busy_line_waits_until_it_is_free(self, lined):
        first = await lined.request(1)
        await back_at_base(lined, "robot-1", first["Id"])
        second = await lined.request(2)
        assert (await lined.get(second["Id"]))["AssignedRobotName"] == "robot-2"
        body = await lined.do(first["Id"], "washing-done")
        assert (body["Status"], body["DeliveryQueued"]) == ("Washing", True)
        await back_at_base(lined, "robot-2", second["Id"])
        body = await lined.get(first["Id"])
        assert (body["Status"], body["AssignedRobotName"]) == (
            "FinishedWashingGoingToRoom", "robot-1")

    async def test_the_front_of_the_base_queue_goes_first(self, lined):
        """Robots at base queue on the line: the one back first is sent first, and one
        waiting to be unloaded holds those behind it."""
        first = await lined.request(1)
        assert first["AssignedRobotName"] == "robot-1"
        await lined.arrive_at_room("robot-1", 1, weight_kg=3.0)
        await lined.do(first["Id"], "confirm-loaded")
        await lined.arrive_at_base("robot-1", weight_kg=3.0)  # behind robot-2, still loaded
        second = await lined.request(3)  # room 201: on no shared line
        assert (second["Status"], second["AssignedRobotName"]) == ("Accepted", "robot-2")
        await lined.arrive_at_room("robot-2", 3, weight_kg=2.0)
        await lined.do(second["Id"], "confirm-loaded")
        await lined.arrive_at_base("robot-2", weight_kg=2.0)  # behind robot-1
        await lined.unloaded("robot-2")
        third = await lined.request(4)
        assert third["Status"] == "Pending"  # robot-2 is free, but robot-1 is in its way
        await lined.unloaded("robot-1")
        assert (await lined.get(third["Id"]))["AssignedRobotName"] == "robot-1"

    async def test_all_rooms_on_one_line_is_the_seeds_any_robot_busy_case(self, db_url):
        """Flowchart 1: "any robot busy -> Pending"."""
        one_line = SITE_TOML + """
[[lines]]
name = "loop"
rooms = ["Room 101", "Room 102", "Room 201", "Room 202"]
"""
        async with Fleet(db_url, site_toml=one_line) as fleet:
            assert (await fleet.request(1))["Status"] == "Accepted"
            assert (await fleet.request(3))["Status"] == "Pending"


class TestNoLines:
    async def test_without_lines_both_robots_go(self, fleet):
        assert [(await fleet.request(c))["Status"] for c in (1, 2)] == ["Accepted"] * 2
        assert (await fleet.http.get("/api/lines")).json() == []


class TestDeclaringLines:
    async def test_the_admin_endpoint_lists_adds_and_removes_lines(self, fleet):
        await fleet.request(1)
        response = await fleet.http.put("/api/lines",
                                        json={"Name": "east", "Rooms": ["Room 101", "Room 102"]})
        assert response.json() == {"Name": "east", "Rooms": ["Room 101", "Room 102"]}
        waiting = await fleet.request(2)
        assert waiting["Status"] == "Pending"
        assert (await fleet.http.get("/api/lines")).json() == [
            {"Name": "east", "Rooms": ["Room 101", "Room 102"]}]
        response = await fleet.http.put("/api/lines", json={"Name": "east", "Rooms": []})
        assert response.json() == {"Name": "east", "Rooms": []}
        assert await fleet.status(waiting["Id"]) == "Accepted"

    async def test_an_unknown_room_is_404_and_bad_bodies_422(self, fleet):
        response = await fleet.http.put("/api/lines", json={"Name": "x", "Rooms": ["Attic"]})
        assert response.status_code == 404
        assert "Attic" in response.json()["detail"]
        for body in ({"Name": "x"}, {"Name": "x", "Rooms": "Room 101"},
                     {"Name": "", "Rooms": []}, {"Name": "x", "Rooms": [3]}):
            response = await fleet.http.put("/api/lines", json=body)
            assert response.status_code == 422, body
        assert (await fleet.http.get("/api/lines")).json() == []

    @pytest.mark.parametrize(("text", "error"), [
        ('[[lines]]\nname = "a"\nrooms = "Room 101"\n', "lines[0].rooms: must be list"),
        ('[[lines]]\nname = "a"\nrooms = [1]\n', "lines[0].rooms[0]: must be a room name"),
        ('[[lines]]\nname = "a"\n', "lines[0]: missing rooms"),
        ('[[lines]]\nname = "a"\nrooms = []\ncolour = "red"\n', "lines[0].colour: unknown"),
    ])
    def test_a_bad_site_file_line_names_the_entry(self, text, error):
        with pytest.raises(SiteError, match=error.replace("[", r"\[").replace("]", r"\]")):
            parse_site(text, "site.toml")

    async def test_a_line_with_an_unknown_room_stops_the_start(self, db_url):
        fleet = Fleet(db_url, site_toml=SITE_TOML + EAST.replace("Room 102", "Attic"))
        with pytest.raises(SiteError, match=r"lines\[0\]\.rooms: room 'Attic' does not exist"):
            await fleet.server.start(monitors=False)
        await fleet.http.aclose()
        await fleet.server.db.dispose()


class TestWhereARobotIs:
    async def test_a_robot_released_away_from_base_holds_the_line_and_is_sent_back(
            self, lined):
        """Seed flowchart 10, "Send Robot to Base": a robot that died on the line holding
        laundry, whose alert the staff resolved (the laundry fetched to base), is still on
        the line, dead or alive, until it reports being back at base; back online it is sent
        there, and then joins the back of the base queue."""
        first = await loaded(lined)
        await offline(lined)
        [alert] = await alerts(lined, open="true")
        assert (await resolve(lined, alert["Id"], "base")).status_code == 200
        second = await lined.request(2)  # the east line: robot-1 lies on it
        assert (second["Status"], second["AssignedRobotName"]) == ("Pending", "robot-2")
        reply = await lined.exchange("robot-1")  # back from its restart, no request
        assert (reply["RequestId"], reply["IsLineFollowing"]) == (None, True)
        assert targets(reply) == {"base-1"}
        assert await lined.status(second["Id"]) == "Pending"
        await lined.arrive_at_base("robot-1")
        body = await lined.get(second["Id"])
        assert (body["Status"], body["AssignedRobotName"]) == ("Accepted", "robot-2")
        reply = await lined.exchange("robot-1")
        assert (reply["IsLineFollowing"], targets(reply)) == (False, set())
        assert await lined.status(first) == "Washing"


class TestTheQueueAtBase:
    """A robot back at base behind another stops short of the base beacon: it reports
    IsInTarget and Queued with the beacon below its threshold (-65 dBm here) but within
    BaseQueueMarginDb (10 dB), and is at base; while it reports Queued the base beacon stays
    its target, so that it pulls up as the queue moves."""

    async def test_a_queued_robot_is_back_at_base_and_keeps_pulling_up(self, lined):
        request_id = await loaded(lined)
        queued = [beacon(BASE_MAC, -72)]
        reply = await lined.exchange("robot-1", beacons=queued, in_target=True,
                                     weight_kg=3.0, Queued=True)
        assert await lined.status(request_id) == "Washing"
        assert (reply["IsLineFollowing"], targets(reply)) == (True, {"base-1"})
        reply = await lined.exchange("robot-1", beacons=[beacon(BASE_MAC, -60)],
                                     in_target=True, weight_kg=3.0)  # at the beacon now
        assert (reply["IsLineFollowing"], targets(reply)) == (False, set())

    async def test_too_far_from_the_base_beacon_is_not_at_base(self, lined):
        request_id = await loaded(lined)
        await lined.exchange("robot-1", beacons=[beacon(BASE_MAC, -76)], in_target=True,
                             weight_kg=3.0, Queued=True)
        assert await lined.status(request_id) == "LaundryLoaded"

    async def test_a_robot_sent_back_before_it_left_keeps_its_place_at_the_front(self, lined):
        """Dispatched, then cancelled while it still stood at base (every report heard the
        base beacon): it never left, so the robots behind it are still behind it and it is
        sent first again. One that went out joins the back."""
        first = await lined.request(1)
        assert first["AssignedRobotName"] == "robot-1"
        await lined.exchange("robot-1", beacons=[beacon(BASE_MAC, -55)])
        await lined.do(first["Id"], "cancel")
        await lined.arrive_at_base("robot-1")
        assert (await lined.request(2))["AssignedRobotName"] == "robot-1"

    async def test_a_robot_that_went_out_joins_the_back(self, lined):
        first = await lined.request(1)
        await lined.exchange("robot-1", beacons=[beacon(BASE_MAC, -90)])  # far from base
        await lined.do(first["Id"], "cancel")
        await lined.arrive_at_base("robot-1")
        assert (await lined.request(2))["AssignedRobotName"] == "robot-2"
