"""The console's second slice over plain HTTP (issue 29): the robots' views, the site map (a
laundry site's schematic, a site's map picture), the robot page and its orders, the settings
form, and the pushed ``robots`` event."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import cv2
import numpy as np
import pytest
from conftest import MakeFleet
from fleet_harness import SITE_TOML, Fleet, loaded, offline
from test_console_http import browser, logged_in

from fleet.console.request_push import RequestChanges
from fleet.console.robot_push import RobotChanges
from fleet.console.robot_views import RobotView, place_rooms, robot_views
from fleet.console.site_svg import loop_point, room_places
from fleet.site import SiteError, load_site, parse_site


async def views(fleet: Fleet) -> dict[str, RobotView]:
    await fleet.server.flush_pings()
    async with fleet.server.db.read() as session:
        return {v.name: v for v in await robot_views(session, fleet.server.clock())}


@pytest.fixture
async def fleet(make_fleet: MakeFleet) -> Fleet:
    return await make_fleet()


class TestRobotViews:
    async def test_a_robot_is_placed_by_what_it_serves(self, fleet: Fleet) -> None:
        """At base, on its way to the customer, at her door, on its way back with the
        laundry; its state, battery and fault as reported."""
        await fleet.exchange("robot-1", State="idle", BatteryPct=77.0)
        view = (await views(fleet))["robot-1"]
        assert (view.place, view.condition, view.battery_pct, view.profile) == (
            "Laundry", "idle", 77.0, "laundry")
        request = await fleet.request(1)
        view = (await views(fleet))["robot-1"]
        assert view.place == "Laundry -> Room 101"
        assert view.condition == "moving"
        assert view.job == f"request {request['Id']}: Accepted"
        await fleet.arrive_at_room("robot-1", 1, weight_kg=3.0)
        assert (await views(fleet))["robot-1"].place == "Room 101"
        await fleet.do(request["Id"], "confirm-loaded")
        assert (await views(fleet))["robot-1"].place == "Room 101 -> Laundry"
        await fleet.exchange("robot-1", Fault={"Code": "bumper", "Message": "pressed"})
        view = (await views(fleet))["robot-1"]
        assert (view.condition, view.fault_code, view.fault_message) == (
            "fault", "bumper", "pressed")
        assert view.x_m is None and view.map_name is None

    async def test_a_silent_robot_is_offline_and_an_estop_shows(self, fleet: Fleet) -> None:
        await loaded(fleet)
        await offline(fleet)
        assert (await views(fleet))["robot-1"].condition == "offline"
        await fleet.http.patch("/api/robots/robot-2", json={"EmergencyStop": True})
        assert (await views(fleet))["robot-2"].condition == "estop"

    def test_a_place_reads_back_as_its_rooms(self) -> None:
        assert place_rooms("A -> B") == ("A", "B")
        assert place_rooms("A") == (None, "A")
        assert place_rooms(None) == (None, None)


class TestRobotsEvent:
    async def test_only_changes_are_pushed(self, fleet: Fleet) -> None:
        """The first pass sends every robot; a pass with nothing changed sends nothing; a
        change sends that robot alone."""
        changes = RobotChanges(fleet.server.db, fleet.server.clock)
        [first] = await changes()
        assert first.event == "robots"
        assert {r["Name"] for r in json.loads(first.data)["Robots"]} == {"robot-1", "robot-2"}
        assert await changes() == []
        await fleet.request(1)
        [event] = await changes()
        [robot] = json.loads(event.data)["Robots"]
        assert (robot["Name"], robot["Place"], robot["Condition"]) == (
            "robot-1", "Laundry -> Room 101", "moving")

    async def test_staff_get_robot_events_on_the_stream_and_customers_do_not(
            self, fleet: Fleet) -> None:
        hub = fleet.server.events
        hub.poll_s = 0.05
        async with hub.subscribe(lambda _n: True, staff=True) as staff, \
                hub.subscribe(lambda _n: False) as customer:
            await fleet.request(1)
            item = await staff.get()
            while not hasattr(item, "event"):
                item = await staff.get()
            assert customer.empty()


class TestRequestEvent:
    async def test_a_customer_is_told_each_status_of_its_own_requests(
            self, fleet: Fleet) -> None:
        """Reaching the laundry room notifies only the staff; the request event tells the
        customer's page, and no other customer's."""
        changes = RequestChanges(fleet.server.db, fleet.server.clock)
        request_id = await loaded(fleet)
        [event] = await changes()
        assert (event.event, event.customer_id) == ("request", 1)
        assert json.loads(event.data) == {"Id": request_id, "Status": "LaundryLoaded"}
        assert await changes() == []
        await fleet.arrive_at_base("robot-1", weight_kg=3.0)
        [event] = await changes()
        assert json.loads(event.data)["Status"] == "Washing"
        hub = fleet.server.events
        hub.poll_s = 0.05
        async with hub.subscribe(lambda _n: False, customer_id=1) as mine, \
                hub.subscribe(lambda _n: False, customer_id=2) as theirs:
            await fleet.unloaded("robot-1")
            await fleet.do(request_id, "washing-done")
            item = await mine.get()
            assert item is not None and getattr(item, "event", None) == "request"
            assert theirs.empty()


class TestSiteMap:
    async def test_only_staff_see_it(self, fleet: Fleet) -> None:
        async with browser(fleet) as client:
            assert (await client.get("/site")).headers["location"] == "/login"
            assert (await client.get("/console/site/robots")).status_code == 401
        async with logged_in(fleet, "customer", "1") as (client, _):
            assert (await client.get("/site")).status_code == 403
            assert (await client.get("/console/site/map.png")).status_code == 403

    async def test_a_laundry_site_is_its_rooms_along_the_loop_with_the_robots(
            self, fleet: Fleet) -> None:
        await fleet.request(1)
        async with logged_in(fleet, "admin", "staff") as (client, _):
            page = (await client.get("/site")).text
            assert 'class="schematic"' in page
            for room in ("Laundry (base)", "Room 101", "Room 202", "Lobby"):
                assert f">{room}</text>" in page
            assert 'id="marker-robot-1"' in page
            assert 'data-place="Laundry -&gt; Room 101"' in page
            assert 'data-condition="moving"' in page
            assert 'href="/site"' in (await client.get("/")).text
            table = (await client.get("/console/site/robots")).text
            assert 'href="/robots/robot-1"' in table
            assert (await client.get("/console/site/map.png")).status_code == 404

    def test_rooms_lie_on_the_loop_in_order(self) -> None:
        places = room_places(["base", "a", "b", "c"])
        assert list(places) == ["base", "a", "b", "c"]
        assert sorted(places.values()) == list(places.values())
        _x, y = loop_point(places["base"])
        assert y == loop_point(places["a"])[1]  # the lower side
        assert loop_point(places["b"])[1] < y  # the upper side

    async def test_a_site_with_a_map_shows_its_picture_and_the_poses(
            self, db_url: str, tmp_path: Path) -> None:
        """The PGM is served as PNG; a robot's pose (made up here: laundry robots report
        none yet) is drawn at its pixel, y flipped."""
        cells = np.full((40, 60), 254, np.uint8)
        cells[0, :] = 0
        cv2.imwrite(str(tmp_path / "yard.pgm"), cells)
        (tmp_path / "yard.yaml").write_text(
            "image: yard.pgm\nresolution: 0.1\norigin: [-1.0, -2.0, 0.0]\nnegate: 0\n"
            "occupied_thresh: 0.65\nfree_thresh: 0.25\n")
        async with Fleet(db_url, site_toml=f'map = "{tmp_path / "yard.yaml"}"\n' + SITE_TOML
                         ) as fleet, logged_in(fleet, "admin", "staff") as (client, _):
            page = (await client.get("/site")).text
            assert 'class="picture"' in page
            assert 'viewBox="0 0 60 40"' in page
            assert "Without a pose on the map (see the table): robot-1, robot-2" in page
            png = await client.get("/console/site/map.png")
            assert png.headers["content-type"] == "image/png"
            decoded = cv2.imdecode(np.frombuffer(png.content, np.uint8), cv2.IMREAD_GRAYSCALE)
            assert decoded.shape == (40, 60)
            assert int(decoded[0, 5]) == 0
        from fleet.console.map_image import load_map
        from fleet.console.site_svg import picture
        site_map = load_map(tmp_path / "yard.yaml")
        posed = RobotView("r", "x", "s", False, None, None, 50.0, 1.0, 0.0, 0.0, "yard", None,
                          None, True, None)
        assert 'transform="translate(20.0,20.0)"' in picture(site_map, [posed], {})

    def test_an_odometry_pose_is_drawn_where_the_site_file_places_its_frame(
            self, tmp_path: Path) -> None:
        """A vacuum's pose on map ``odom`` goes through its ``odom_on_map``: frame at (1, 0),
        turned 90 degrees, so odom (1, 0) is map (1, 1); a robot on another map, or an odom
        pose without a placement, is not drawn."""
        from fleet.console.map_image import load_map
        from fleet.console.site_svg import on_site_map, picture
        cv2.imwrite(str(tmp_path / "yard.pgm"), np.full((40, 60), 254, np.uint8))
        (tmp_path / "yard.yaml").write_text("image: yard.pgm\nresolution: 0.1\n"
                                            "origin: [-1.0, -2.0, 0.0]\n")
        site_map = load_map(tmp_path / "yard.yaml")
        site = parse_site('[[robots]]\nname = "vac"\nodom_on_map = [1.0, 0.0, 90]\n'
                          '[[robots]]\nname = "other"\n')
        placements = site.odom_placements()

        def view(name: str, map_name: str) -> RobotView:
            return RobotView(name, "vacuum", "s", False, None, None, None, 1.0, 0.0, 0.5,
                             map_name, None, None, True, None)

        x, y, theta = on_site_map(view("vac", "odom"), site_map, placements) or (0, 0, 0)
        assert (round(x, 6), round(y, 6)) == (1.0, 1.0)
        assert theta == pytest.approx(0.5 + math.pi / 2)
        assert on_site_map(view("other", "odom"), site_map, placements) is None
        assert on_site_map(view("vac", "warehouse"), site_map, placements) is None
        drawn = picture(site_map, [view("vac", "odom"), view("other", "odom")], placements)
        assert 'transform="translate(20.0,10.0)"' in drawn
        assert "marker-other" not in drawn

    def test_a_bad_odometry_placement_is_named(self) -> None:
        with pytest.raises(SiteError, match=r"site: robots\[0\]\.odom_on_map: must be "
                                            r"\[x_m, y_m, theta_deg\]"):
            parse_site('[[robots]]\nname = "vac"\nodom_on_map = [1.0, "a", 0]\n', "site")
        with pytest.raises(SiteError, match=r"robots\[0\]\.odom_on_map: must be list"):
            parse_site('[[robots]]\nname = "vac"\nodom_on_map = 3\n', "site")


    def test_a_bad_map_is_named_and_the_schematic_shown(self, tmp_path: Path) -> None:
        with pytest.raises(SiteError, match=r"site: map: must be the path of a map YAML"):
            parse_site("map = 3\n", "site")
        (tmp_path / "site.toml").write_text('map = "maps/none.yaml"\n')
        assert load_site(tmp_path / "site.toml").map == tmp_path / "maps/none.yaml"

    async def test_a_map_that_cannot_be_read_does_not_break_the_page(
            self, db_url: str, tmp_path: Path) -> None:
        (tmp_path / "bad.yaml").write_text("image: gone.pgm\nresolution: 0.05\n"
                                           "origin: [0, 0, 0]\n")
        async with Fleet(db_url, site_toml=f'map = "{tmp_path / "bad.yaml"}"\n' + SITE_TOML
                         ) as fleet, logged_in(fleet, "admin", "staff") as (client, _):
            page = await client.get("/site")
            assert page.status_code == 200
            assert "cannot read" in page.text and 'class="schematic"' in page.text
            assert (await client.get("/console/site/map.png")).status_code == 404


class TestRobotPage:
    async def test_staff_stop_resume_and_maintain_a_robot(self, fleet: Fleet) -> None:
        """Each order is a CSRF form; the robot's next reply carries it; a button that does
        nothing now is shown disabled with the reason."""
        async with logged_in(fleet, "admin", "staff") as (client, csrf):
            page = (await client.get("/robots/robot-1")).text
            assert re.search(r'disabled title="no e-stop of the server\'s to lift" '
                             r'data-action="resume"', page.replace("&#x27;", "'"))
            assert (await client.post("/robots/robot-1/estop")).status_code == 403
            assert (await client.post("/robots/robot-1/estop", data={"csrf": csrf})
                    ).headers["location"] == "/robots/robot-1"
            assert (await fleet.exchange("robot-1"))["EmergencyStop"] is True
            again = await client.post("/robots/robot-1/estop", data={"csrf": csrf})
            assert again.status_code == 409
            assert "already stopped" in again.text
            await client.post("/robots/robot-1/resume", data={"csrf": csrf})
            assert (await fleet.exchange("robot-1"))["EmergencyStop"] is False
            await client.post("/robots/robot-1/maintenance", data={"csrf": csrf})
            assert (await fleet.exchange("robot-1"))["MaintenanceMode"] is True
            assert 'data-action="end-maintenance"' in (
                await client.get("/robots/robot-1/view")).text
            assert (await client.get("/robots/nobody")).status_code == 404
            assert (await client.post("/robots/robot-1/explode", data={"csrf": csrf})
                    ).status_code == 404

    async def test_it_shows_what_the_server_saw_of_the_robot(self, fleet: Fleet) -> None:
        request_id = await loaded(fleet)
        await offline(fleet)
        async with logged_in(fleet, "admin", "staff") as (client, _):
            history = (await client.get("/robots/robot-1/history")).text
            assert "robot.offline" in history
            assert f"<td>{request_id}</td><td>LaundryLoaded</td>" in history
            assert 'data-condition="offline"' in (await client.get("/robots/robot-1")).text
        async with logged_in(fleet, "customer", "1") as (client, csrf):
            assert (await client.get("/robots/robot-1")).status_code == 403
            assert (await client.post("/robots/robot-1/estop", data={"csrf": csrf})
                    ).status_code == 403


class TestSettingsPage:
    async def test_staff_change_a_setting(self, fleet: Fleet) -> None:
        async with logged_in(fleet, "admin", "staff") as (client, csrf):
            page = (await client.get("/settings")).text
            assert 'name="AutoAccept"' in page and 'name="WebhookUrls"' in page
            saved = await client.post("/settings", data={
                "csrf": csrf, "AutoAccept": "false", "ArrivedTimeoutS": "120",
                "WebhookUrls": "http://hooks.example/a\n"})
            assert saved.headers["location"] == "/settings?saved=1"
        cfg = (await fleet.http.get("/api/settings")).json()
        assert (cfg["AutoAccept"], cfg["ArrivedTimeoutS"], cfg["WebhookUrls"]) == (
            False, 120.0, ["http://hooks.example/a"])

    @pytest.mark.parametrize(("field", "value", "says"), [
        ("ArrivedTimeoutS", "-5", "greater than 0"),
        ("ArrivedTimeoutS", "soon", "'soon' is not a number"),
        ("WebhookRetries", "1.5", "not a whole number"),
        ("AutoAccept", "maybe", "must be yes or no"),
        ("WebhookUrls", "ftp://x", "should match pattern"),
        ("ArrivedTimeoutS", "1e999", "less than or equal"),
    ])
    async def test_a_bad_value_is_shown_beside_its_field_and_nothing_is_stored(
            self, fleet: Fleet, field: str, value: str, says: str) -> None:
        before = (await fleet.http.get("/api/settings")).json()
        async with logged_in(fleet, "admin", "staff") as (client, csrf):
            refused = await client.post("/settings", data={
                "csrf": csrf, "AutoAccept": "false", field: value})
            assert refused.status_code == 400
            error = re.search(rf'id="error-{field}" role="alert">([^<]*)<', refused.text)
            assert error is not None and says in error.group(1).replace("&#x27;", "'")
        assert (await fleet.http.get("/api/settings")).json() == before

    async def test_values_that_do_not_hold_together_are_refused(self, fleet: Fleet) -> None:
        async with logged_in(fleet, "admin", "staff") as (client, csrf):
            refused = await client.post("/settings", data={
                "csrf": csrf, "MinWeightKg": "5", "MaxWeightKg": "4"})
            assert refused.status_code == 409
            assert "MinWeightKg must be below MaxWeightKg" in refused.text
            assert 'value="5"' in refused.text
            flood = "&".join(f"f{i}=1" for i in range(100)) + f"&csrf={csrf}"
            posted = await client.post("/settings", content=flood, headers={
                "content-type": "application/x-www-form-urlencoded"})
            assert posted.status_code == 403
