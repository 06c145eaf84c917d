"""Every robot on the fleet (issue 29): any robot's site status (``POST /api/Robot/{name}/
status``) is stored and shown to staff, its faults raise alerts, and the staff's e-stop,
resume and maintenance come back in the answer."""

from __future__ import annotations

from collections.abc import AsyncIterator
from typing import Any

import pytest
from fleet_harness import SITE_TOML, Fleet, bearer, token_for

from fleet.services.robot_status import robot_statuses

OTHERS = ("vac-1", "relay-1")
SITE = SITE_TOML + "".join(f"""
[[robots]]
name = "{name}"

[[tokens]]
role = "robot"
subject = "{name}"
token = "{token_for('robot', name)}"
""" for name in OTHERS)


@pytest.fixture
async def site(db_url: str) -> AsyncIterator[Fleet]:
    """The test site with a vacuum and a RelayBot beside the laundry robots (which alone
    make data exchanges)."""
    fleet = Fleet(db_url, site_toml=SITE)
    fleet.reporting = ["robot-1", "robot-2"]
    await fleet.__aenter__()
    yield fleet
    await fleet.__aexit__(None, None, None)


def vacuum_status(**extra: Any) -> dict[str, Any]:
    return {"RobotName": "vac-1", "Profile": "vacuum", "State": "mission.cleaning",
            "EmergencyStopActive": False, "Fault": None, "BatteryPct": 76.5,
            "Pose": {"X": 1.25, "Y": -0.5, "Theta": 0.7854, "Map": "odom"}, "Place": None,
            "Job": None, **extra}


async def post_status(fleet: Fleet, robot: str = "vac-1", expect: int = 200,
                      **body: Any) -> dict[str, Any]:
    response = await fleet.http.post(f"/api/Robot/{robot}/status", json=body)
    assert response.status_code == expect, response.text
    answer: dict[str, Any] = response.json()
    return answer


class TestStored:
    async def test_the_status_is_shown_in_the_robot_list(self, site):
        """Profile, state, battery, pose, job: what GET /api/robots shows for staff."""
        answer = await post_status(site, **vacuum_status())
        assert answer == {"EmergencyStop": False, "MaintenanceMode": False}
        await post_status(site, "relay-1", RobotName="relay-1", Profile="delivery",
                          State="mission.to_warehouse", Job="order 7",
                          Pose={"X": 3.0, "Y": 2.0, "Theta": -1.5, "Map": "depot"})
        robots = await site.robots()
        vac = robots["vac-1"]
        assert (vac["Profile"], vac["State"], vac["BatteryPct"], vac["Pose"], vac["Job"]) == (
            "vacuum", "mission.cleaning", 76.5,
            {"X": 1.25, "Y": -0.5, "Theta": 0.7854, "Map": "odom"}, None)
        assert vac["LastStatusAt"] is not None
        relay = robots["relay-1"]
        assert (relay["Profile"], relay["Job"], relay["Pose"]["Map"]) == (
            "delivery", "order 7", "depot")

    async def test_a_robot_on_a_line_reports_its_place(self, site):
        await post_status(site, Profile="vacuum", Place="Room 101", Pose=None)
        vac = (await site.robots())["vac-1"]
        assert (vac["Place"], vac["Pose"]) == ("Room 101", None)

    async def test_robot_statuses_give_one_view_per_robot_online_while_it_reports(self, site):
        """The console's read: every robot, online while its reports keep coming."""
        await post_status(site, **vacuum_status())
        async with site.server.db.read() as session:
            views = {v.name: v for v in await robot_statuses(session, site.clock())}
        vac = views["vac-1"]
        assert (vac.profile, vac.x_m, vac.y_m, vac.theta_rad, vac.map_name) == (
            "vacuum", 1.25, -0.5, 0.7854, "odom")
        assert vac.online and vac.last_seen == site.clock()
        assert not views["relay-1"].online and views["relay-1"].last_seen is None
        assert views["robot-1"].online  # a laundry robot by its data exchange
        site.clock.advance(31)  # OfflineAfterS is 30 by default
        async with site.server.db.read() as session:
            views = {v.name: v for v in await robot_statuses(session, site.clock())}
        assert not views["vac-1"].online

    async def test_the_console_shows_what_a_reporting_robot_says_of_itself(self, site):
        """The console's robot views take a reporting robot's status (its profile, pose and
        map, fault, job); a laundry robot keeps the place the server knows; a robot that
        never reported has no profile yet."""
        from fleet.console.robot_views import robot_views

        await post_status(site, **vacuum_status(
            State="recovery", Fault={"Code": "dock_failed", "Message": "fallbacks spent"}))
        await site.server.flush_pings()
        async with site.server.db.read() as session:
            views = {v.name: v for v in await robot_views(session, site.clock())}
        vac = views["vac-1"]
        assert (vac.profile, vac.state, vac.battery_pct, vac.x_m, vac.y_m, vac.theta_rad,
                vac.map_name) == ("vacuum", "recovery", 76.5, 1.25, -0.5, 0.7854, "odom")
        assert (vac.condition, vac.fault_code, vac.online) == ("fault", "dock_failed", True)
        assert (views["robot-1"].profile, views["robot-1"].place) == ("laundry", "Laundry")
        assert views["relay-1"].profile is None and not views["relay-1"].online
        site.clock.advance(31)
        async with site.server.db.read() as session:
            later = {v.name: v for v in await robot_views(session, site.clock())}
        assert later["vac-1"].condition == "offline"

    async def test_a_robot_that_only_reports_status_is_never_sent_a_request(self, db_url):
        """A vacuum is not a laundry robot: with no laundry robot online, no request can be
        served, however well the vacuum reports."""
        fleet = Fleet(db_url, site_toml=SITE)
        fleet.reporting = []
        async with fleet:
            await post_status(fleet, **vacuum_status())
            response = await fleet.create(1)
            assert response.status_code == 503, response.text


class TestFaults:
    async def test_docking_gave_up_raises_an_alert_until_the_fault_clears(self, site):
        await post_status(site, **vacuum_status(
            State="recovery", Fault={"Code": "dock_failed", "Message": "fallbacks spent"}))
        alerts = (await site.http.get("/api/alerts", params={"open": "true"})).json()
        assert [(a["Kind"], a["Code"], a["RobotName"]) for a in alerts] == [
            ("robot.fault", "docking_gave_up", "vac-1")]
        kinds = [n["Kind"] for n in await site.notifications(recipient="admin")]
        assert "robot.fault" in kinds  # pushed to the event stream as every notification
        await post_status(site, **vacuum_status())
        assert (await site.http.get("/api/alerts", params={"open": "true"})).json() == []
        closed = (await site.http.get("/api/alerts")).json()
        assert closed[0]["Resolution"] == "FaultCleared"

    async def test_a_relaybot_error_category_is_the_alerts_code(self, site):
        await post_status(site, "relay-1", Profile="delivery", State="mission.error_recovery",
                          Fault={"Code": "stuck", "Message": "error recovery: stuck"})
        alert = (await site.http.get("/api/alerts", params={"open": "true"})).json()[0]
        assert (alert["Code"], alert["RobotName"]) == ("stuck", "relay-1")

    async def test_staff_resolve_a_fault_alert_as_any_other(self, site):
        await post_status(site, "relay-1", Fault={"Code": "no_path", "Message": "none"})
        alert = (await site.http.get("/api/alerts")).json()[0]
        response = await site.http.post(f"/api/alerts/{alert['Id']}/resolve")
        assert response.status_code == 200, response.text
        assert response.json()["ResolvedBy"] == "staff"


    async def test_the_alert_is_pushed_on_the_staffs_event_stream(self, site):
        """The staff's open SSE stream has the fault's notification as it is raised."""
        from test_push import STAFF, Listener, serving

        async with serving(site.app) as url, Listener(url, STAFF) as listener:
            await post_status(site, "relay-1", Profile="delivery",
                              Fault={"Code": "stuck", "Message": "error recovery: stuck"})
            _came, kind, data = await listener.next()
            assert (kind, data["RobotName"], data["Level"]) == ("robot.fault", "relay-1",
                                                                "warning")
            assert "stuck" in data["Message"]


class TestOrders:
    async def test_estop_resume_and_maintenance_come_back_in_the_answer(self, site):
        await post_status(site, **vacuum_status())
        response = await site.http.post("/api/robots/vac-1/estop")
        assert response.status_code == 200, response.text
        assert response.json()["EmergencyStop"] is True
        assert await post_status(site, **vacuum_status()) == {
            "EmergencyStop": True, "MaintenanceMode": False}
        assert (await site.http.post("/api/robots/vac-1/resume")).status_code == 200
        assert (await post_status(site, **vacuum_status()))["EmergencyStop"] is False
        response = await site.http.post("/api/robots/vac-1/maintenance", json={"On": True})
        assert response.status_code == 200, response.text
        assert (await post_status(site, **vacuum_status()))["MaintenanceMode"] is True
        await site.http.post("/api/robots/vac-1/maintenance", json={"On": False})
        assert (await post_status(site, **vacuum_status()))["MaintenanceMode"] is False
        orders = [n["Message"] for n in await site.notifications(recipient="admin")
                  if n["Kind"] == "robot.order"]
        assert len(orders) == 4 and "staff ordered estop of robot vac-1." in orders

    async def test_the_existing_patch_gives_the_same_order(self, site):
        await site.http.patch("/api/robots/vac-1", json={"EmergencyStop": True})
        assert (await post_status(site, **vacuum_status()))["EmergencyStop"] is True

    async def test_an_order_for_an_unknown_robot_is_404(self, site):
        assert (await site.http.post("/api/robots/nobody/estop")).status_code == 404
        response = await site.http.post("/api/robots/vac-1/maintenance", json={"On": "yes"})
        assert response.status_code == 422


class TestRefused:
    async def test_another_robots_token_is_403(self, site):
        response = await site.http.post("/api/Robot/vac-1/status", json=vacuum_status(),
                                        headers=bearer(token_for("robot", "relay-1")))
        assert response.status_code == 403

    async def test_a_customer_token_is_403_and_none_is_401(self, site):
        response = await site.http.post("/api/Robot/vac-1/status", json={},
                                        headers=bearer(token_for("customer", "1")))
        assert response.status_code == 403
        response = await site.http.post("/api/Robot/vac-1/status", json={},
                                        headers={"Authorization": "Bearer nope-nope-nope"})
        assert response.status_code == 401

    async def test_a_body_naming_another_robot_is_422(self, site):
        await post_status(site, expect=422, **vacuum_status(RobotName="relay-1"))

    @pytest.mark.parametrize("bad", [
        {"Pose": {"X": "1", "Y": 0, "Theta": 0}},
        {"Pose": {"X": 1e9, "Y": 0, "Theta": 0}},
        {"Pose": {"X": 0, "Y": 0, "Theta": 10}},
        {"BatteryPct": 101},
        {"Fault": {"Message": "no code"}},
        {"Job": "x" * 201},
        {"Profile": "a\nb"},
    ])
    async def test_bad_values_are_422(self, site, bad):
        await post_status(site, expect=422, **vacuum_status(**bad))


class TestTheLaundryExchangeCarriesTheSameFields:
    async def test_profile_place_and_job_ride_on_the_data_exchange(self, site):
        """A laundry robot says them in its data exchange (added fields); quiet reports
        write them with the batched pings."""
        await site.exchange("robot-1", Profile="laundry", Place="Room 101")
        writes = site.server.db.generation
        await site.exchange("robot-1", Profile="laundry", Place="Laundry", Job="request 3")
        assert site.server.db.generation == writes
        robot = (await site.robots())["robot-1"]
        assert (robot["Profile"], robot["Place"], robot["Job"]) == (
            "laundry", "Laundry", "request 3")

    async def test_a_laundry_robots_job_is_its_request(self, site):
        request = await site.request(1)  # accepted at once (AutoAccept), a robot dispatched
        async with site.server.db.read() as session:
            views = {v.name: v for v in await robot_statuses(session, site.clock())}
        assert views[request["AssignedRobotName"]].job == f"request {request['Id']}"

    async def test_bad_added_fields_are_422(self, site):
        response = await site.http.post("/api/Robot/robot-1/data-exchange",
                                        json={"Place": "", "Profile": "laundry"})
        assert response.status_code == 422
