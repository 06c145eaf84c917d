"""The fleet server's data-exchange response, checked field by field."""

from __future__ import annotations

from typing import Any

import pytest

from behaviours.profiles.laundry.directive import BadResponse, Directive, parse_exchange_response

GOOD: dict[str, Any] = {
    "ActiveBeacons": [
        {"MacAddress": "AA:00:00:00:00:01", "Name": "r101", "RoomName": "101",
         "RssiThreshold": -60, "IsNavigationTarget": True},
        {"MacAddress": "AA:00:00:00:00:02", "Name": "base", "RoomName": "base",
         "RssiThreshold": -62, "IsNavigationTarget": False},
    ],
    "IsLineFollowing": True,
    "FollowColor": "red",
    "EmergencyStop": False,
    "MaintenanceMode": False,
}


class TestParseExchangeResponse:
    def test_reads_the_contract_fields(self) -> None:
        d = parse_exchange_response(GOOD)
        assert d.line_following is True
        assert d.follow_color == "red"
        assert d.target_rooms() == ["101"]
        assert len(d.active_beacons) == 2

    @pytest.mark.parametrize(("body", "message"), [
        ([], r"response: expected a JSON object, got list"),
        ("ok", r"response: expected a JSON object, got str"),
        ({**GOOD, "IsLineFollowing": "yes"}, r"response.IsLineFollowing: expected true or false"),
        ({**GOOD, "EmergencyStop": 1}, r"response.EmergencyStop: expected true or false"),
        ({**GOOD, "FollowColor": 7}, r"response.FollowColor: expected a string or null"),
        ({**GOOD, "ActiveBeacons": {"a": 1}}, r"response.ActiveBeacons: expected a list"),
        ({**GOOD, "ActiveBeacons": [1]}, r"response.ActiveBeacons\[0\]: expected an object"),
    ])
    def test_a_body_of_the_wrong_shape_names_the_field(self, body: Any, message: str) -> None:
        with pytest.raises(BadResponse, match=message):
            parse_exchange_response(body)

    def test_missing_flags_mean_false_and_empty_colour_means_none(self) -> None:
        d = parse_exchange_response({"FollowColor": ""})
        assert d == Directive(line_following=False)

    def test_target_rooms_are_listed_once_in_order(self) -> None:
        beacons = [{"RoomName": "103", "IsNavigationTarget": True},
                   {"RoomName": "103", "IsNavigationTarget": True},
                   {"RoomName": "base", "IsNavigationTarget": True},
                   {"RoomName": "101", "IsNavigationTarget": "yes"}]
        d = parse_exchange_response({"ActiveBeacons": beacons})
        assert d.target_rooms() == ["103", "base"]
