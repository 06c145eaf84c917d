"""The robot's half of the data exchange: what it sends the fleet server every period."""

from __future__ import annotations

from collections.abc import Callable
from datetime import UTC
from typing import Any

from behaviours.beacons.arrival import Arrival
from behaviours.beacons.tracker import BeaconTracker
from behaviours.profiles.laundry.load_check import LoadCheck
from hal.devices import RangeSensor
from hal.ports import WallClock


class RobotReport:
    """Builds the data-exchange request (PascalCase, DESIGN.md "Fleet data exchange")."""

    def __init__(self, robot_name: str, wall_clock: WallClock, tracker: BeaconTracker,
                 arrival: Arrival, load: LoadCheck | None, front_range: RangeSensor | None,
                 holding: Callable[[], dict[str, Any] | None] | None = None) -> None:
        self.robot_name = robot_name
        self.wall_clock = wall_clock
        self.tracker = tracker
        self.arrival = arrival
        self.load = load
        self.front_range = front_range
        self.holding = holding

    def build(self) -> dict[str, Any]:
        weight = self.load.weight().kg if self.load is not None else None
        reading = self.front_range.latest() if self.front_range is not None else None
        stamp = self.wall_clock().astimezone(UTC).isoformat().replace("+00:00", "Z")
        report: dict[str, Any] = {
            "RobotName": self.robot_name,
            "Timestamp": stamp,
            "DetectedBeacons": self.tracker.detected_beacons(),
            "IsInTarget": self.arrival.is_in_target,
            "WeightKg": round(weight, 3) if weight is not None else None,
            "UltrasonicDistance": round(reading.distance_cm, 1) if reading is not None else None,
        }
        held = self.holding() if self.holding is not None else None
        if held is not None:
            # An extension of the contract (the server ignores names it does not know): what
            # the robot carries and whose, e.g. after a restart with laundry aboard.
            report["Holding"] = held
        return report
