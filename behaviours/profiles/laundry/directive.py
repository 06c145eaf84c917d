"""What the robot is told to do, by the fleet server's data-exchange response (seed 000 s. 8).

The response is checked field by field; a body of the wrong shape is refused with a message
that names the field, and the robot keeps its last directive rather than guessing.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

_FLAGS = ("IsLineFollowing", "EmergencyStop", "MaintenanceMode")


class BadResponse(ValueError):
    """The server's response does not have the contract's shape; the message names the field."""


@dataclass(frozen=True, slots=True)
class Directive:
    line_following: bool
    follow_color: str | None = None
    active_beacons: tuple[dict[str, Any], ...] = field(default_factory=tuple)
    emergency_stop: bool = False
    maintenance: bool = False
    request_id: int | None = None
    """The request the robot serves (``RequestId``, an extension of the contract), if told."""
    request_status: str | None = None

    @classmethod
    def stand_still(cls) -> Directive:
        """No line following, no target: what the robot does without a server."""
        return cls(line_following=False)

    def target_rooms(self) -> list[str]:
        """Room names of the navigation-target beacons, in order, once each."""
        rooms: list[str] = []
        for entry in self.active_beacons:
            room = str(entry.get("RoomName") or "")
            if entry.get("IsNavigationTarget") is True and room and room not in rooms:
                rooms.append(room)
        return rooms


def parse_exchange_response(body: Any) -> Directive:
    """The contract's response object as a Directive; BadResponse naming the field otherwise."""
    if not isinstance(body, dict):
        msg = f"response: expected a JSON object, got {type(body).__name__}"
        raise BadResponse(msg)
    flags: dict[str, bool] = {}
    for name in _FLAGS:
        value = body.get(name, False)
        if not isinstance(value, bool):
            msg = f"response.{name}: expected true or false, got {value!r}"
            raise BadResponse(msg)
        flags[name] = value
    colour = body.get("FollowColor")
    if colour is not None and not isinstance(colour, str):
        msg = f"response.FollowColor: expected a string or null, got {colour!r}"
        raise BadResponse(msg)
    beacons = body.get("ActiveBeacons", [])
    if not isinstance(beacons, list):
        msg = f"response.ActiveBeacons: expected a list, got {type(beacons).__name__}"
        raise BadResponse(msg)
    for i, entry in enumerate(beacons):
        if not isinstance(entry, dict):
            msg = f"response.ActiveBeacons[{i}]: expected an object"
            raise BadResponse(msg)
    request_id = body.get("RequestId")
    if request_id is not None and (isinstance(request_id, bool)
                                   or not isinstance(request_id, int)):
        msg = f"response.RequestId: expected an integer or null, got {request_id!r}"
        raise BadResponse(msg)
    request_status = body.get("RequestStatus")
    if request_status is not None and not isinstance(request_status, str):
        msg = f"response.RequestStatus: expected a string or null, got {request_status!r}"
        raise BadResponse(msg)
    return Directive(
        request_id=request_id,
        request_status=request_status,
        line_following=flags["IsLineFollowing"],
        follow_color=colour or None,
        active_beacons=tuple(beacons),
        emergency_stop=flags["EmergencyStop"],
        maintenance=flags["MaintenanceMode"],
    )
