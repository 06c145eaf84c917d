"""Alerts for the laundry staff (issue 27): raised for a robot offline holding laundry, a robot's
fault and a stuck request; acknowledged and resolved by staff, a laundry alert with where the
laundry is, which moves the request and its robot to a consistent state."""

from __future__ import annotations

import pytest
from fleet_harness import (
    alerts,
    bearer,
    delivering,
    loaded,
    offline,
    resolve,
    targets,
    token_for,
)


class TestOfflineWithLaundry:
    async def test_a_robot_offline_holding_laundry_raises_one_critical_alert(self, fleet):
        """Seed 13: the alert is stored (and AdminAlert reads as before); another monitor
        pass does not raise it again."""
        request_id = await loaded(fleet)
        await offline(fleet)
        [alert] = await alerts(fleet, open="true")
        assert (alert["Kind"], alert["Level"], alert["RobotName"], alert["RequestId"],
                alert["IsLaundry"]) == ("robot.offline.laundry", "critical", "robot-1",
                                        request_id, True)
        assert (await fleet.get(request_id))["AdminAlert"] is not None
        fleet.clock.advance(31)
        await fleet.exchange("robot-2")
        await fleet.server.check_offline()
        assert len(await alerts(fleet)) == 1

    async def test_the_robot_back_online_resolves_it(self, fleet):
        request_id = await loaded(fleet)
        await offline(fleet)
        await fleet.exchange("robot-1", weight_kg=3.0)
        assert await alerts(fleet, open="true") == []
        [alert] = await alerts(fleet, open="false")
        assert (alert["ResolvedBy"], alert["Resolution"]) == ("robot-1", "RobotReconnected")
        assert (await fleet.get(request_id))["AdminAlert"] is None

    async def test_laundry_on_the_robot_keeps_request_and_robot_together(self, fleet):
        request_id = await loaded(fleet)
        await offline(fleet)
        [alert] = await alerts(fleet, open="true")
        response = await resolve(fleet, alert["Id"], "robot")
        assert response.status_code == 200, response.text
        assert (response.json()["Resolution"], response.json()["ResolvedBy"]) == (
            "LaundryRobot", "staff")
        assert await fleet.status(request_id) == "LaundryLoaded"
        assert (await fleet.robots())["robot-1"]["CurrentRequestId"] == request_id

    async def test_dirty_laundry_at_base_goes_on_as_washing_and_frees_the_robot(self, fleet):
        request_id = await loaded(fleet)
        await offline(fleet)
        [alert] = await alerts(fleet, open="true")
        assert (await resolve(fleet, alert["Id"], "base")).status_code == 200
        body = await fleet.get(request_id)
        assert (body["Status"], body["AdminAlert"]) == ("Washing", None)
        assert (await fleet.robots())["robot-1"]["CurrentRequestId"] is None
        await fleet.exchange("robot-2")
        await fleet.do(request_id, "washing-done")  # delivered by the robot that is online
        assert (await fleet.get(request_id))["AssignedRobotName"] == "robot-2"

    async def test_clean_laundry_at_base_is_held_for_delivery_again(self, fleet):
        """Clean laundry the staff took off the robot waits at base as Washing (washing
        started): the next washing-done sends it out with a free robot."""
        request_id = await delivering(fleet)
        await offline(fleet)
        [alert] = await alerts(fleet, open="true")
        assert (await resolve(fleet, alert["Id"], "base")).status_code == 200
        assert await fleet.status(request_id) == "Washing"
        kinds = [n["Kind"] for n in await fleet.notifications(request_id=request_id)]
        assert "laundry.held_at_base" in kinds
        await fleet.exchange("robot-2")
        body = await fleet.do(request_id, "washing-done")
        assert (body["Status"], body["AssignedRobotName"]) == (
            "FinishedWashingGoingToRoom", "robot-2")

    async def test_laundry_returned_to_the_customer_ends_the_request_with_a_refund(self, fleet):
        request_id = await loaded(fleet)
        await fleet.do(request_id, "pay")
        await offline(fleet)
        [alert] = await alerts(fleet, open="true")
        assert (await resolve(fleet, alert["Id"], "customer")).status_code == 200
        body = await fleet.get(request_id)
        assert (body["Status"], body["LaundryDisposition"], body["RefundDue"]) == (
            "Cancelled", "LaundryReturnedToCustomer", True)
        assert (await fleet.robots())["robot-1"]["CurrentRequestId"] is None


class TestStaffCancelWhileOffline:
    async def test_the_laundry_is_said_to_be_on_the_robot_until_resolved(self, fleet):
        """Cancelling a request whose robot is offline with the laundry does not pretend the
        laundry is at base: LaundryOnRobot, the alert stays open, and the robot keeps the
        request, even back online and at base, until the staff resolve the alert."""
        request_id = await loaded(fleet)
        await offline(fleet)
        body = await fleet.do(request_id, "cancel")
        assert (body["Status"], body["LaundryDisposition"]) == ("Cancelled", "LaundryOnRobot")
        assert (await fleet.robots())["robot-1"]["CurrentRequestId"] == request_id
        reply = await fleet.exchange("robot-1", weight_kg=3.0)  # back online
        assert targets(reply) == {"base-1"}
        [alert] = await alerts(fleet, open="true")
        await fleet.arrive_at_base("robot-1", weight_kg=3.0)
        assert (await fleet.robots())["robot-1"]["CurrentRequestId"] == request_id
        assert (await fleet.get(request_id))["LaundryDisposition"] == "LaundryOnRobot"
        assert (await resolve(fleet, alert["Id"], "base")).status_code == 200
        body = await fleet.get(request_id)
        assert (body["Status"], body["LaundryDisposition"]) == ("Cancelled",
                                                                "DirtyLaundryAtBase")
        assert (await fleet.robots())["robot-1"]["CurrentRequestId"] is None


class TestFaults:
    async def test_one_alert_per_fault_code_while_it_lasts(self, fleet):
        async def fault(code: str | None) -> None:
            response = await fleet.http.post("/api/Robot/robot-1/data-exchange", json={
                "Fault": {"Code": code, "Message": f"{code} now"} if code else None})
            assert response.status_code == 200, response.text

        await fault("line_lost")
        await fault("line_lost")
        [alert] = await alerts(fleet, open="true")
        assert (alert["Kind"], alert["RobotName"], alert["IsLaundry"]) == (
            "robot.fault", "robot-1", False)
        assert "line_lost" in alert["Message"]
        await fault("blocked")
        [now_open] = await alerts(fleet, open="true")
        assert "blocked" in now_open["Message"]
        await fault(None)
        assert await alerts(fleet, open="true") == []
        resolved = await alerts(fleet, open="false")
        assert {a["Resolution"] for a in resolved} == {"FaultCleared"}
        await fault("line_lost")
        assert len(await alerts(fleet, open="true")) == 1

    async def test_staff_resolve_a_fault_alert_without_a_laundry_place(self, fleet):
        await fleet.http.post("/api/Robot/robot-1/data-exchange",
                              json={"Fault": {"Code": "line_lost"}})
        [alert] = await alerts(fleet, open="true")
        response = await resolve(fleet, alert["Id"], "base")
        assert response.status_code == 422
        assert "LaundryAt" in response.json()["detail"]
        response = await resolve(fleet, alert["Id"])
        assert (response.status_code, response.json()["Resolution"]) == (200, "Resolved")


class TestStuck:
    async def test_a_loaded_robot_that_does_not_reach_base_raises_an_alert(self, make_fleet):
        """LaundryLoadedTimeoutS: the request is not cancelled (the robot holds the laundry);
        one alert, AdminAlert shows it; reaching base resolves it."""
        fleet = await make_fleet(LaundryLoadedTimeoutS=120)
        request_id = await loaded(fleet)
        fleet.clock.advance(100)
        await fleet.report_all()
        assert await fleet.server.check_timeouts() == []
        assert await alerts(fleet) == []
        fleet.clock.advance(25)
        await fleet.report_all()
        assert await fleet.server.check_timeouts() == []
        [alert] = await alerts(fleet, open="true")
        assert (alert["Kind"], alert["Level"], alert["RequestId"], alert["IsLaundry"]) == (
            "request.stuck", "critical", request_id, True)
        body = await fleet.get(request_id)
        assert (body["Status"], body["AdminAlert"] is not None) == ("LaundryLoaded", True)
        fleet.clock.advance(20)
        await fleet.report_all()
        await fleet.server.check_timeouts()
        assert len(await alerts(fleet)) == 1
        await fleet.arrive_at_base("robot-1", weight_kg=3.0)
        assert await alerts(fleet, open="true") == []
        body = await fleet.get(request_id)
        assert (body["Status"], body["AdminAlert"]) == ("Washing", None)

    async def test_a_robot_late_back_from_a_delivery_raises_a_warning(self, make_fleet):
        fleet = await make_fleet(GoingToBaseTimeoutS=60)
        request_id = await delivering(fleet)
        await fleet.arrive_at_room("robot-1", 1, weight_kg=0.0)
        await fleet.do(request_id, "confirm-unloaded")
        fleet.clock.advance(61)
        await fleet.report_all()
        await fleet.server.check_timeouts()
        [alert] = await alerts(fleet, open="true")
        assert (alert["Kind"], alert["Level"]) == ("request.stuck", "warning")
        assert await fleet.status(request_id) == "FinishedWashingGoingToBase"

    async def test_the_timeouts_are_settings(self, fleet):
        values = await fleet.settings(LaundryLoadedTimeoutS=900, GoingToBaseTimeoutS=300)
        assert (values["LaundryLoadedTimeoutS"], values["GoingToBaseTimeoutS"]) == (900, 300)
        response = await fleet.http.put("/api/settings", json={"GoingToBaseTimeoutS": 0})
        assert response.status_code == 422


class TestStaffOnly:
    @pytest.mark.parametrize("who", [("customer", "1"), ("robot", "robot-1")])
    async def test_customers_and_robots_get_403(self, fleet, who):
        await fleet.http.post("/api/Robot/robot-1/data-exchange",
                              json={"Fault": {"Code": "line_lost"}})
        token = bearer(token_for(*who))
        assert (await fleet.http.get("/api/alerts", headers=token)).status_code == 403
        for action in ("acknowledge", "resolve"):
            response = await fleet.http.post(f"/api/alerts/1/{action}", headers=token)
            assert response.status_code == 403
        [alert] = await alerts(fleet)
        assert (alert["AcknowledgedAt"], alert["ResolvedAt"]) == (None, None)

    async def test_acknowledge_records_who_and_resolved_alerts_are_409(self, fleet):
        await fleet.http.post("/api/Robot/robot-1/data-exchange",
                              json={"Fault": {"Code": "line_lost"}})
        response = await fleet.http.post("/api/alerts/1/acknowledge")
        assert (response.status_code, response.json()["AcknowledgedBy"]) == (200, "staff")
        assert response.json()["ResolvedAt"] is None
        assert (await resolve(fleet, 1)).status_code == 200
        assert (await resolve(fleet, 1)).status_code == 409
        assert (await fleet.http.post("/api/alerts/1/acknowledge")).status_code == 409
        assert (await fleet.http.post("/api/alerts/99/acknowledge")).status_code == 404

    async def test_a_laundry_alert_needs_laundry_at(self, fleet):
        await loaded(fleet)
        await offline(fleet)
        [alert] = await alerts(fleet, open="true")
        response = await resolve(fleet, alert["Id"])
        assert response.status_code == 422
        assert "LaundryAt" in response.json()["detail"]
        response = await fleet.http.post(f"/api/alerts/{alert['Id']}/resolve",
                                         json={"LaundryAt": "kitchen"})
        assert response.status_code == 422
        assert "LaundryAt" in response.json()["detail"]
        assert len(await alerts(fleet, open="true")) == 1
