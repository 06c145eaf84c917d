"""Bad input gets a 4xx with a message and changes nothing; the site file is checked."""

from __future__ import annotations

import re

import pytest
from fleet_harness import bearer, token_for

from fleet.api.schemas import DataExchangeOut
from fleet.site import SiteError, parse_site


async def snapshot(fleet):
    requests = (await fleet.http.get("/api/requests")).json()
    robots = await fleet.robots()
    for robot in robots.values():
        robot.pop("LastPingAt")
    settings = (await fleet.http.get("/api/settings")).json()
    return requests, robots, settings


BAD_CREATES = [
    ("malformed JSON", b'{"CustomerId": 1', 422),
    ("not JSON at all", b"CustomerId=1", 422),
    ("a string id", b'{"CustomerId": "1"}', 422),
    ("a boolean id", b'{"CustomerId": true}', 422),
    ("a fractional id", b'{"CustomerId": 1.5}', 422),
    ("a negative id", b'{"CustomerId": -1}', 422),
    ("an id beyond 32 bits", b'{"CustomerId": 1099511627776}', 422),
    ("a missing id", b"{}", 422),
    ("an extra field", b'{"CustomerId": 1, "Priority": 9}', 422),
    ("a list body", b"[1]", 422),
    ("an unknown customer", b'{"CustomerId": 77}', 404),
]

BAD_EXCHANGES = [
    ("malformed JSON", "robot-1", b'{"IsInTarget": tru', 422),
    ("a string flag", "robot-1", b'{"IsInTarget": "yes"}', 422),
    ("a NaN weight", "robot-1", b'{"WeightKg": NaN}', 422),
    ("an infinite distance", "robot-1", b'{"UltrasonicDistance": Infinity}', 422),
    ("a text RSSI", "robot-1", b'{"DetectedBeacons": [{"MacAddress": "x", "Rssi": "-50"}]}', 422),
    ("beacons not a list", "robot-1", b'{"DetectedBeacons": {"MacAddress": "x"}}', 422),
    ("another robot's name", "robot-1", b'{"RobotName": "robot-2"}', 422),
    ("an unknown robot (robot-1's token)", "robot-9", b"{}", 403),
    ("a control character in the name", "robot%01", b"{}", 422),
]


class TestBodySize:
    async def test_a_body_announced_over_the_limit_is_refused_unread(self, fleet):
        """A 2 MiB body (the limit is 1 MiB; a real report is a few hundred bytes): 413 with
        a message, nothing changed."""
        before = await snapshot(fleet)
        body = b'{"IsInTarget": false, "Pad": "' + b"x" * (2 * 1024 * 1024) + b'"}'
        response = await fleet.http.post("/api/Robot/robot-1/data-exchange", content=body,
                                         headers={"content-type": "application/json"})
        assert response.status_code == 413
        assert "over the 1048576 byte limit" in response.json()["detail"]
        assert await snapshot(fleet) == before

    async def test_a_chunked_body_is_refused_once_it_passes_the_limit(self, fleet):
        async def chunks():
            yield b'{"CustomerId": 1, "Pad": "'
            for _ in range(40):
                yield b"x" * 65536
            yield b'"}'

        before = await snapshot(fleet)
        response = await fleet.http.post("/api/requests", content=chunks(),
                                         headers={"content-type": "application/json"})
        assert response.status_code == 413
        assert await snapshot(fleet) == before


class TestBadRequests:
    @pytest.mark.parametrize(("what", "body", "code"), BAD_CREATES,
                             ids=[w for w, _, _ in BAD_CREATES])
    async def test_bad_request_bodies_are_refused(self, fleet, what, body, code):
        before = await snapshot(fleet)
        response = await fleet.http.post("/api/requests", content=body,
                                         headers={"content-type": "application/json"})
        assert response.status_code == code, what
        assert response.json()["detail"]
        assert await snapshot(fleet) == before

    @pytest.mark.parametrize(("what", "robot", "body", "code"), BAD_EXCHANGES,
                             ids=[w for w, _, _, _ in BAD_EXCHANGES])
    async def test_bad_data_exchanges_are_refused(self, fleet, what, robot, body, code):
        await fleet.request(1)
        before = await snapshot(fleet)
        response = await fleet.http.post(
            f"/api/Robot/{robot}/data-exchange", content=body,
            headers={"content-type": "application/json",
                     **bearer(token_for("robot", "robot-1"))})
        assert response.status_code == code, what
        assert response.json()["detail"]
        assert await snapshot(fleet) == before

    async def test_unknown_requests_and_actions(self, fleet):
        assert (await fleet.act(12345, "accept")).status_code == 404
        assert (await fleet.http.get("/api/requests/12345")).status_code == 404
        assert (await fleet.http.get("/api/requests/0")).status_code == 422
        request = await fleet.request(1)
        response = await fleet.act(request["Id"], "teleport")
        assert response.status_code == 422
        assert "accept" in response.json()["detail"]

    async def test_an_action_out_of_turn_is_409_and_changes_nothing(self, fleet):
        request = await fleet.request(1)
        before = await snapshot(fleet)
        for action in ("accept", "decline", "confirm-loaded", "confirm-unloaded",
                       "washing-done", "washing-started"):
            response = await fleet.act(request["Id"], action)
            assert response.status_code == 409, action
            assert "Accepted" in response.json()["detail"]
        assert await snapshot(fleet) == before

    @pytest.mark.parametrize("body", [
        {"MinWeightKg": 20.0}, {"AcceptedTimeoutS": -1}, {"AutoAccept": "yes please"},
        {"Colour": "red"}, {"OfflineAfterS": 0},
    ], ids=["min-above-max", "negative-timeout", "text-flag", "unknown-key", "zero-period"])
    async def test_bad_settings_are_refused(self, fleet, body):
        before = await snapshot(fleet)
        response = await fleet.http.put("/api/settings", json=body)
        # Each key valid, the whole not (MinWeightKg above the stored MaxWeightKg): 409.
        assert response.status_code == (409 if body == {"MinWeightKg": 20.0} else 422)
        assert response.json()["detail"]
        assert await snapshot(fleet) == before

    async def test_bad_admin_input(self, fleet):
        cases = [
            ("post", "/api/robots", {"Name": "robot-1"}, 409),
            ("post", "/api/robots", {"Name": ""}, 422),
            ("patch", "/api/robots/robot-7", {"IsActive": False}, 404),
            ("patch", "/api/robots/robot-1", {"IsActive": "no"}, 422),
            ("put", "/api/beacons", {"MacAddress": "zz", "Name": "b", "RoomName": "Lobby"}, 422),
            ("put", "/api/beacons", {"MacAddress": "C3:00:00:00:09:09", "Name": "b",
                                     "RoomName": "Attic"}, 404),
            ("post", "/api/customers", {"Name": "Zed", "BeaconMacAddress": "C3:00:00:00:09:09"},
             404),
            ("put", "/api/rooms", {"Name": "x\x00y"}, 422),
            # The column holds 32 characters: PostgreSQL answered a longer one with a 500.
            ("put", "/api/rooms", {"Name": "Attic", "FloorColor": "c" * 33}, 422),
        ]
        before = await snapshot(fleet)
        for method, path, body, code in cases:
            response = await fleet.http.request(method.upper(), path, json=body)
            assert response.status_code == code, (method, path, body, response.text)
            assert response.json()["detail"]
        assert await snapshot(fleet) == before

    async def test_the_reply_matches_its_documented_schema(self, fleet):
        await fleet.request(1)
        response = await fleet.http.post("/api/Robot/robot-1/data-exchange", json={})
        reply = DataExchangeOut.model_validate_json(response.content)
        assert reply.IsLineFollowing is True
        assert response.headers["content-type"] == "application/json"


class TestSiteFile:
    @pytest.mark.parametrize(("text", "message"), [
        ("[[rooms]]\nname = 3\n", "rooms[0].name: must be str"),
        ("[[rooms]]\ncolour = 'x'\n", "rooms[0].colour: unknown key"),
        ("[[beacons]]\nmac = 'C3:00:00:00:00:01'\n", "beacons[0]: missing name, room"),
        ("[garden]\n", "garden: unknown section"),
        ("[[robots]]\nname = \n", "site.toml"),
        ("rooms = 3\n", "rooms: must be an array of tables"),
        ("[[beacons]]\nmac='a'\nname='b'\nroom='c'\nrssi_threshold_dbm=true\n",
         "beacons[0].rssi_threshold_dbm: must be int"),
        ("[[rooms]]\nname = 'a'\nfloor_color = '" + "c" * 33 + "'\n",
         "rooms[0].floor_color: at most 32 characters, got 33"),
    ])
    def test_bad_site_files_name_the_entry(self, text, message):
        with pytest.raises(SiteError, match=r"site\.toml") as info:
            parse_site(text, "site.toml")
        assert message in str(info.value)

    async def test_a_site_naming_an_unknown_room_fails_at_start(self, tmp_path):
        from fleet_harness import Fleet

        fleet = Fleet(f"sqlite:///{tmp_path / 'x.db'}",
                      site_toml="[[beacons]]\nmac='C3:00:00:00:00:01'\nname='b'\nroom='Nowhere'\n")
        with pytest.raises(SiteError, match="room 'Nowhere' does not exist"):
            await fleet.server.start(monitors=False)
        await fleet.server.db.dispose()
        await fleet.http.aclose()

    @pytest.mark.parametrize(("entry", "message"), [
        ('role = "robot"\nsubject = "robot-1"\ntoken = "short"',
         "tokens[0]: a token must have 24 to 512 characters"),
        ('role = "root"\nsubject = "x"\ntoken = "long-enough-token-0123456789"',
         "tokens[0].role: must be one of robot, customer, admin"),
        ('role = "robot"\nsubject = "robot-9"\ntoken = "long-enough-token-0123456789"',
         "tokens[0]: robot 'robot-9' is not registered"),
    ])
    async def test_a_bad_token_entry_fails_at_start_naming_it(self, tmp_path, entry, message):
        from fleet_harness import Fleet

        fleet = Fleet(f"sqlite:///{tmp_path / 'x.db'}",
                      site_toml=f"[[robots]]\nname = 'robot-1'\n[[tokens]]\n{entry}\n")
        with pytest.raises(SiteError, match=re.escape(message)):
            await fleet.server.start(monitors=False)
        await fleet.server.db.dispose()
        await fleet.http.aclose()

    def test_the_example_site_loads(self):
        from pathlib import Path

        import fleet

        site = Path(fleet.__file__).parent / "sites" / "example.toml"
        parsed = parse_site(site.read_text(), str(site))
        assert [r["name"] for r in parsed.robots] == ["robot-1", "robot-2"]
        assert parsed.settings["AutoAccept"] is True
