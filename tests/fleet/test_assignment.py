"""Duplicate rejection, auto-assignment, approval, the FIFO queue and preemption (seed
sections 1, 3 and 9), and no double assignment under parallel clients."""

from __future__ import annotations

import asyncio

from fleet_harness import Fleet


async def finish_at_base(fleet: Fleet, robot: str, request_id: int) -> None:
    """Drive an accepted request until the robot is back at base with it (Washing)."""
    customer = (await fleet.get(request_id))["CustomerId"]
    await fleet.arrive_at_room(robot, customer, weight_kg=3.0)
    await fleet.do(request_id, "confirm-loaded")
    await fleet.arrive_at_base(robot, weight_kg=3.0)
    assert await fleet.status(request_id) == "Washing"
    await fleet.unloaded(robot)  # the staff take the laundry off: the robot is free


class TestDuplicateRequests:
    async def test_a_customer_with_an_active_request_is_refused(self, fleet):
        """A second request while the first is active is 409 and creates nothing."""
        first = await fleet.request(1)
        response = await fleet.create(1)
        assert response.status_code == 409
        assert str(first["Id"]) in response.json()["detail"]
        listed = (await fleet.http.get("/api/requests", params={"customer_id": 1})).json()
        assert [r["Id"] for r in listed] == [first["Id"]]

    async def test_a_customer_may_ask_again_once_the_request_is_over(self, fleet):
        """Only active requests count as duplicates."""
        first = await fleet.request(1)
        await fleet.do(first["Id"], "cancel")
        assert (await fleet.create(1)).status_code == 201

    async def test_an_unknown_customer_is_404(self, fleet):
        response = await fleet.create(99)
        assert response.status_code == 404
        assert "customer 99" in response.json()["detail"]


class TestAutoAssignment:
    async def test_the_first_available_robot_is_taken(self, fleet):
        """Robots are taken in order; a busy robot is skipped."""
        assert (await fleet.request(1))["AssignedRobotName"] == "robot-1"
        assert (await fleet.request(2))["AssignedRobotName"] == "robot-2"

    async def test_no_robot_at_all_is_503(self, fleet):
        """With no active online robot the request is refused and not stored."""
        for name in ("robot-1", "robot-2"):
            await fleet.http.patch(f"/api/robots/{name}", json={"IsActive": False})
        response = await fleet.create(1)
        assert response.status_code == 503
        assert "no robot" in response.json()["detail"]
        assert (await fleet.http.get("/api/requests")).json() == []

    async def test_offline_and_stopped_robots_do_not_count(self, fleet):
        """Only active online robots serve: offline, maintenance and estop ones do not."""
        await fleet.http.patch("/api/robots/robot-1", json={"MaintenanceMode": True})
        await fleet.http.patch("/api/robots/robot-2", json={"EmergencyStop": True})
        assert (await fleet.create(1)).status_code == 503
        await fleet.http.patch("/api/robots/robot-2", json={"EmergencyStop": False})
        assert (await fleet.request(1))["AssignedRobotName"] == "robot-2"

    async def test_without_auto_accept_requests_wait_for_the_admin(self, make_fleet):
        """AutoAccept off: Pending with a robot named, until an admin accepts."""
        fleet = await make_fleet(AutoAccept=False)
        body = await fleet.request(1)
        assert (body["Status"], body["IsApproved"]) == ("Pending", False)
        assert (await fleet.robots())["robot-1"]["Status"] == "Available"
        kinds = {n["Kind"] for n in await fleet.notifications(recipient="admin")}
        assert "request.approval_needed" in kinds

    async def test_auto_accept_can_be_switched_at_run_time(self, fleet):
        """PUT /api/settings changes AutoAccept for the next request."""
        assert (await fleet.settings(AutoAccept=False))["AutoAccept"] is False
        assert (await fleet.request(1))["Status"] == "Pending"
        await fleet.settings(AutoAccept=True)
        assert (await fleet.request(2))["Status"] == "Accepted"


class TestQueue:
    async def test_requests_beyond_the_robots_wait_and_go_in_fifo_order(self, make_fleet):
        """With both robots busy, later requests queue; a freed robot takes the oldest."""
        fleet = await make_fleet(PreemptBusyRobot=False)
        r1, r2 = await fleet.request(1), await fleet.request(2)
        r3, r4 = await fleet.request(3), await fleet.request(4)
        assert [r["Status"] for r in (r1, r2, r3, r4)] == ["Accepted", "Accepted", "Pending",
                                                          "Pending"]
        await finish_at_base(fleet, "robot-2", r2["Id"])
        assert await fleet.status(r3["Id"]) == "Accepted"
        assert (await fleet.get(r3["Id"]))["AssignedRobotName"] == "robot-2"
        assert await fleet.status(r4["Id"]) == "Pending"
        await finish_at_base(fleet, "robot-1", r1["Id"])
        assert (await fleet.get(r4["Id"]))["AssignedRobotName"] == "robot-1"

    async def test_an_approved_request_waits_until_a_robot_is_free(self, make_fleet):
        """Admin approval with every robot busy keeps it Pending (approved) in the queue."""
        fleet = await make_fleet(AutoAccept=False, PreemptBusyRobot=False)
        ids = [(await fleet.request(c))["Id"] for c in (1, 2, 3)]
        for request_id in ids:
            await fleet.do(request_id, "accept")
        assert [await fleet.status(i) for i in ids] == ["Accepted", "Accepted", "Pending"]
        assert (await fleet.get(ids[2]))["IsApproved"]
        await fleet.do(ids[0], "cancel")
        assert await fleet.status(ids[2]) == "Pending"  # robot-1 must first be back at base
        await fleet.arrive_at_base("robot-1")
        assert await fleet.status(ids[2]) == "Accepted"

    async def test_a_reconnecting_robot_serves_the_queue(self, make_fleet):
        """Restore on reconnect processes the queue."""
        fleet = await make_fleet(PreemptBusyRobot=False)
        fleet.clock.advance(60)
        await fleet.exchange("robot-2")
        assert await fleet.server.check_offline() == ["robot-1"]
        r1, r2 = await fleet.request(1), await fleet.request(2)
        assert (r1["Status"], r2["Status"]) == ("Accepted", "Pending")
        await fleet.exchange("robot-1")
        assert (await fleet.get(r2["Id"]))["AssignedRobotName"] == "robot-1"


class TestPreemption:
    async def test_by_default_a_busy_robot_is_neither_taken_nor_named(self, fleet):
        """No preemption by default: with every robot busy the new request waits Pending
        with no robot named, and the busy robots' requests are left alone."""
        r1, r2 = await fleet.request(1), await fleet.request(2)
        r3 = await fleet.request(3)
        assert (r3["Status"], r3["AssignedRobotName"]) == ("Pending", None)
        for request in (r1, r2):
            kinds = [n["Kind"] for n in await fleet.notifications(request_id=request["Id"])]
            assert "request.requeued" not in kinds

    async def test_preemption_names_the_least_recently_assigned_robot_without_churn(
            self, make_fleet):
        """Seed section 3 with the FIFO queue: the least recently assigned busy robot is
        named for the new request, but its own request is not reset (it would get the same
        robot straight back): no requeued notice, no fresh navigation timer. (This test
        used to require the spurious request.requeued notice.)"""
        fleet = await make_fleet(PreemptBusyRobot=True)
        r1 = await fleet.request(1)
        fleet.clock.advance(5)
        r2 = await fleet.request(2)
        fleet.clock.advance(5)
        r3 = await fleet.request(3)
        assert (r3["Status"], r3["AssignedRobotName"]) == ("Pending", "robot-1")
        kinds = [n["Kind"] for n in await fleet.notifications(request_id=r1["Id"])]
        assert "request.requeued" not in kinds
        after = await fleet.get(r1["Id"])
        assert (after["Status"], after["StatusChangedAt"]) == ("Accepted", r1["StatusChangedAt"])
        robots = await fleet.robots()
        assert robots["robot-1"]["CurrentRequestId"] == r1["Id"]
        # The first robot free serves the new request (FIFO), named or not.
        await finish_at_base(fleet, "robot-2", r2["Id"])
        body = await fleet.get(r3["Id"])
        assert (body["Status"], body["AssignedRobotName"]) == ("Accepted", "robot-2")

    async def test_robots_holding_laundry_are_never_named(self, make_fleet):
        """Only robots still on their way (Accepted) are named."""
        fleet = await make_fleet(PreemptBusyRobot=True)
        r1, r2 = await fleet.request(1), await fleet.request(2)
        for robot, request in (("robot-1", r1), ("robot-2", r2)):
            await fleet.arrive_at_room(robot, request["CustomerId"], weight_kg=3.0)
            await fleet.do(request["Id"], "confirm-loaded")
        r3 = await fleet.request(3)
        assert (r3["Status"], r3["AssignedRobotName"]) == ("Pending", None)
        assert await fleet.status(r1["Id"]) == "LaundryLoaded"


class TestParallelClients:
    async def test_parallel_requests_never_share_a_robot(self, fleet):
        """Many customers at once: each robot serves at most one request."""
        await fleet.settings(PreemptBusyRobot=False)
        results = await asyncio.gather(*(fleet.create(c) for c in (1, 2, 3, 4, 1, 2)))
        created = [r.json() for r in results if r.status_code == 201]
        assert sorted(r.status_code for r in results) == [201, 201, 201, 201, 409, 409]
        accepted = [r for r in created if r["Status"] == "Accepted"]
        assert len(accepted) == 2
        assert len({r["AssignedRobotName"] for r in accepted}) == 2

    async def test_parallel_approvals_and_reports_never_double_assign(self, make_fleet):
        """Accepts, cancels and robot reports racing each other keep one request per robot."""
        fleet = await make_fleet(AutoAccept=False, PreemptBusyRobot=False)
        ids = [(await fleet.request(c))["Id"] for c in (1, 2, 3, 4)]
        calls = [fleet.act(i, "accept") for i in ids]
        calls += [fleet.exchange(r) for r in ("robot-1", "robot-2")]
        calls += [fleet.act(ids[0], "cancel")]
        await asyncio.gather(*calls)
        robots = await fleet.robots()
        serving = [r["CurrentRequestId"] for r in robots.values() if r["CurrentRequestId"]]
        assert len(serving) == len(set(serving))
        for request_id in ids:
            body = await fleet.get(request_id)
            if body["Status"] == "Accepted":
                assert robots[body["AssignedRobotName"]]["CurrentRequestId"] == request_id

    async def test_two_servers_on_one_database_never_double_assign(self, make_fleet):
        """Two server instances (as behind a load balancer) share the database safely."""
        one = await make_fleet(PreemptBusyRobot=False)
        two = await make_fleet()
        results = await asyncio.gather(*(
            (one if i % 2 else two).create(c) for i, c in enumerate((1, 2, 3, 4, 1, 3))))
        assert sorted(r.status_code for r in results) == [201, 201, 201, 201, 409, 409]
        robots = await one.robots()
        serving = [r["CurrentRequestId"] for r in robots.values() if r["CurrentRequestId"]]
        assert len(serving) == 2
        assert len(set(serving)) == 2
