"""The timeout monitor (seed section 10), offline robots (section 13), cancellation branches
(section 12), and the monitors running on virtual time."""

from __future__ import annotations

import asyncio
from datetime import UTC, datetime
from functools import partial

import pytest
from fleet_harness import SITE_TOML, SiteAuth, beacon

from fleet.app import create_app
from fleet.clock import loop_clock
from fleet.services.timeouts import any_timed_out
from fleet.site import parse_site
from sim import vclock

ROBOT = "robot-1"


async def to_loaded(fleet, customer=1):
    request = await fleet.request(customer)
    await fleet.arrive_at_room(ROBOT, customer, weight_kg=2.0)
    await fleet.do(request["Id"], "confirm-loaded")
    return request["Id"]


async def to_delivery(fleet, customer=1):
    request_id = await to_loaded(fleet, customer)
    await fleet.arrive_at_base(ROBOT)
    await fleet.unloaded(ROBOT)
    await fleet.do(request_id, "washing-done")
    return request_id


class TestTimeoutMonitor:
    async def test_each_timeout_is_tunable(self, fleet):
        """Nothing times out before its setting; the settings can be changed at run time."""
        request = await fleet.request(1)
        await fleet.settings(AcceptedTimeoutS=120)
        fleet.clock.advance(119)
        await fleet.exchange(ROBOT)
        assert await fleet.server.check_timeouts() == []
        fleet.clock.advance(2)
        assert await fleet.server.check_timeouts() == [request["Id"]]
        body = await fleet.get(request["Id"])
        assert body["CancelReason"] == "NavigationTimeout"

    async def test_a_customer_who_never_loads_is_cancelled_and_the_robot_goes_home(self, fleet):
        request = await fleet.request(1)
        await fleet.arrive_at_room(ROBOT, 1)
        fleet.clock.advance(301)
        await fleet.exchange(ROBOT)
        assert await fleet.server.check_timeouts() == [request["Id"]]
        body = await fleet.get(request["Id"])
        assert (body["Status"], body["CancelReason"]) == ("Cancelled", "LoadTimeout")
        reply = await fleet.exchange(ROBOT)
        assert {b["Name"] for b in reply["ActiveBeacons"] if b["IsNavigationTarget"]} == {
            "base-1"}
        assert reply["IsLineFollowing"] is True
        texts = [n["Message"] for n in await fleet.notifications(request_id=request["Id"])]
        assert any("not loaded" in t for t in texts)
        assert (await fleet.robots())[ROBOT]["IsOffline"] is False

    async def test_a_silent_robot_is_marked_offline_on_timeout(self, fleet):
        """Robot not still active: it is marked offline (it cannot be sent home)."""
        request = await fleet.request(1)
        fleet.clock.advance(700)
        assert await fleet.server.check_timeouts() == [request["Id"]]
        assert (await fleet.robots())[ROBOT]["IsOffline"] is True

    async def test_a_timeout_serves_the_queue_once_the_robot_is_home(self, make_fleet):
        fleet = await make_fleet(PreemptBusyRobot=False)
        await fleet.http.patch("/api/robots/robot-2", json={"IsActive": False})
        first = await fleet.request(1)
        second = await fleet.request(2)
        fleet.clock.advance(700)
        await fleet.exchange(ROBOT)
        await fleet.server.check_timeouts()
        assert await fleet.status(second["Id"]) == "Pending"
        await fleet.arrive_at_base(ROBOT)
        assert (await fleet.get(first["Id"]))["RobotReturned"] is True
        assert await fleet.status(second["Id"]) == "Accepted"


class TestQuietPasses:
    @pytest.mark.parametrize("stage", ["Accepted", "ArrivedAtRoom", "FinishedWashingGoingToRoom"])
    @pytest.mark.parametrize("past_limit_s", [-1.0, 0.0, 1e-6, 1.0])
    async def test_the_quick_check_says_whether_the_monitor_cancels(self, make_fleet, stage,
                                                                     past_limit_s):
        """``any_timed_out`` is true exactly when ``check_timeouts`` cancels something: just
        before, at and just after each watched status's limit."""
        fleet = await make_fleet(AcceptedTimeoutS=100, ArrivedTimeoutS=50)
        if stage == "Accepted":
            request_id, limit_s = (await fleet.request(1))["Id"], 100
        elif stage == "ArrivedAtRoom":
            request_id, limit_s = (await fleet.request(1))["Id"], 50
            await fleet.arrive_at_room(ROBOT, 1)
        else:
            request_id, limit_s = await to_delivery(fleet), 100
        assert await fleet.status(request_id) == stage
        fleet.clock.advance(limit_s + past_limit_s)
        quick = await fleet.server.db.run_read(partial(any_timed_out, now=fleet.clock()))
        assert quick == (await fleet.server.check_timeouts() == [request_id])
        assert quick == (past_limit_s > 0)
        assert not await fleet.server.db.run_read(partial(any_timed_out, now=fleet.clock()))


class TestCancellationBranches:
    async def test_cancel_en_route_sends_the_robot_to_base(self, fleet):
        request = await fleet.request(1)
        await fleet.do(request["Id"], "cancel")
        robots = await fleet.robots()
        assert robots[ROBOT]["Status"] == "Busy"  # still on its way home
        await fleet.exchange(ROBOT, beacons=[beacon("C3:00:00:00:01:01")], in_target=True)
        assert (await fleet.robots())[ROBOT]["Status"] == "Busy"  # not at base yet
        await fleet.arrive_at_base(ROBOT)
        assert (await fleet.robots())[ROBOT]["Status"] == "Available"

    async def test_cancel_with_laundry_aboard_brings_it_to_base(self, fleet):
        request_id = await to_loaded(fleet)
        body = await fleet.do(request_id, "cancel")
        assert body["LaundryDisposition"] == "DirtyLaundryAtBase"
        await fleet.arrive_at_base(ROBOT)
        assert (await fleet.robots())[ROBOT]["Status"] == "Available"

    async def test_cancel_before_washing_returns_dirty_laundry(self, fleet):
        request_id = await to_loaded(fleet)
        await fleet.arrive_at_base(ROBOT)
        body = await fleet.do(request_id, "cancel")
        assert body["LaundryDisposition"] == "ReturnDirtyToCustomer"

    async def test_cancel_during_washing_lets_the_admin_finish(self, fleet):
        request_id = await to_loaded(fleet)
        await fleet.arrive_at_base(ROBOT)
        await fleet.do(request_id, "washing-started")
        assert (await fleet.act(request_id, "washing-started")).status_code == 409
        body = await fleet.do(request_id, "cancel")
        assert body["LaundryDisposition"] == "FinishWashingThenDeliverOrReturn"
        admin = await fleet.notifications(recipient="admin", request_id=request_id)
        assert any(n["Kind"] == "request.cancelled.washing" for n in admin)

    async def test_cancel_during_delivery_holds_clean_laundry_at_base(self, fleet):
        request_id = await to_delivery(fleet)
        body = await fleet.do(request_id, "cancel")
        assert body["LaundryDisposition"] == "None"
        await fleet.arrive_at_base(ROBOT)
        body = await fleet.get(request_id)
        assert (body["LaundryDisposition"], body["RobotReturned"]) == (
            "CleanLaundryHeldAtBase", True)

    async def test_a_paid_request_is_flagged_for_refund(self, fleet):
        request_id = await to_loaded(fleet)  # paying is allowed once the laundry is loaded
        await fleet.do(request_id, "pay")
        body = await fleet.do(request_id, "cancel")
        assert body["RefundDue"] is True
        request = {"Id": request_id}
        texts = [n["Message"] for n in await fleet.notifications(request_id=request["Id"])]
        assert any("refund" in t for t in texts)

    async def test_an_unpaid_request_needs_no_refund(self, fleet):
        request = await fleet.request(1)
        assert (await fleet.do(request["Id"], "cancel"))["RefundDue"] is False


class TestOfflineRobots:
    async def test_a_robot_that_stops_pinging_goes_offline(self, fleet):
        fleet.clock.advance(20)
        await fleet.exchange("robot-2")
        fleet.clock.advance(15)
        assert await fleet.server.check_offline() == [ROBOT]
        robots = await fleet.robots()
        assert (robots[ROBOT]["Status"], robots["robot-2"]["Status"]) == ("Offline",
                                                                          "Available")

    async def test_offline_en_route_cancels_and_notifies(self, fleet):
        """(Nothing is paid yet on the way to the customer: no refund is due.)"""
        request = await fleet.request(1)
        fleet.clock.advance(31)
        await fleet.exchange("robot-2")
        await fleet.server.check_offline()
        body = await fleet.get(request["Id"])
        assert (body["Status"], body["CancelReason"], body["RefundDue"]) == (
            "Cancelled", "RobotOffline", False)
        customer = await fleet.notifications(recipient="customer", request_id=request["Id"])
        assert any("Service disruption" in n["Message"] for n in customer)

    async def test_offline_with_laundry_raises_a_critical_alert(self, fleet):
        request_id = await to_loaded(fleet)
        fleet.clock.advance(31)
        await fleet.exchange("robot-2")
        await fleet.server.check_offline()
        body = await fleet.get(request_id)
        assert body["Status"] == "LaundryLoaded"
        assert body["AdminAlert"]
        admin = await fleet.notifications(recipient="admin", request_id=request_id)
        assert [n["Level"] for n in admin if n["Kind"] == "robot.offline.laundry"] == [
            "critical"]

    async def test_offline_with_clean_laundry_raises_a_critical_alert(self, fleet):
        request_id = await to_delivery(fleet)
        fleet.clock.advance(31)
        await fleet.exchange("robot-2")
        await fleet.server.check_offline()
        assert (await fleet.get(request_id))["Status"] == "FinishedWashingGoingToRoom"
        assert (await fleet.get(request_id))["AdminAlert"]

    async def test_a_pending_request_of_an_offline_robot_stays_pending(self, make_fleet):
        fleet = await make_fleet(AutoAccept=False)
        request = await fleet.request(1)
        fleet.clock.advance(31)
        await fleet.server.check_offline()
        assert await fleet.status(request["Id"]) == "Pending"

    async def test_reconnecting_restores_the_robot_and_clears_the_alert(self, fleet):
        request_id = await to_loaded(fleet)
        fleet.clock.advance(31)
        await fleet.server.check_offline()
        reply = await fleet.exchange(ROBOT, weight_kg=2.0)
        robots = await fleet.robots()
        assert (robots[ROBOT]["IsOffline"], robots[ROBOT]["Status"]) == (False, "Busy")
        assert (await fleet.get(request_id))["AdminAlert"] is None
        assert reply["IsLineFollowing"] is True  # resumes the trip to base
        await fleet.arrive_at_base(ROBOT)
        assert await fleet.status(request_id) == "Washing"


class TestMonitorsOnVirtualTime:
    def test_the_monitors_cancel_on_their_own_in_virtual_time(self, tmp_path):
        """On robotd's virtual-time loop the monitors run every 10 s / 30 s of loop time, and
        with inline SQLite no DB work is under way outside the loop while its clock jumps: a
        2-minute timeout costs nothing and fires at the first monitor pass after it."""
        import httpx

        async def main() -> tuple[str, float, bool]:
            loop = asyncio.get_running_loop()
            clock = loop_clock(datetime(2026, 1, 5, tzinfo=UTC), loop.time)
            app = create_app(f"sqlite:///{tmp_path / 'v.db'}",
                             site=parse_site(SITE_TOML), clock=clock,
                             settings={"AcceptedTimeoutS": 120}, inline_sqlite=True)
            await app.state.fleet.start()
            transport = httpx.ASGITransport(app=app)
            async with httpx.AsyncClient(transport=transport, base_url="http://f",
                                         auth=SiteAuth()) as http:
                for name in ("robot-1", "robot-2"):  # online means reported
                    await http.post(f"/api/Robot/{name}/data-exchange", json={})
                created = (await http.post("/api/requests", json={"CustomerId": 1})).json()
                start = loop.time()
                while True:
                    # The robot keeps reporting (so it is never offline) but never arrives.
                    for name in ("robot-1", "robot-2"):
                        await http.post(f"/api/Robot/{name}/data-exchange", json={})
                    body = (await http.get(f"/api/requests/{created['Id']}")).json()
                    if body["Status"] != "Accepted" or loop.time() - start > 900:
                        break
                    await asyncio.sleep(5.0)
                robots = (await http.get("/api/robots")).json()
            await app.state.fleet.stop()
            return body["Status"], loop.time() - start, robots[0]["IsOffline"]

        status, waited_s, offline = vclock.run(main())
        assert status == "Cancelled"
        assert 120 <= waited_s <= 135
        assert offline is False
