"""The robot's half of the data exchange: what it sends the fleet server every period."""

from __future__ import annotations

from collections.abc import Callable
from datetime import UTC
from typing import Any

from behaviours.beacons.arrival import Arrival
from behaviours.beacons.tracker import BeaconTracker
from behaviours.context import RobotContext
from behaviours.motion.obstacle_guard import ObstacleGuard
from behaviours.profile import SiteFacts
from behaviours.profiles.laundry.base_queue import BaseQueue
from behaviours.profiles.laundry.load_check import LoadCheck
from behaviours.profiles.laundry.states import FOLLOWING
from behaviours.site_report.status import site_fields
from hal.devices import RangeSensor
from hal.ports import WallClock

BLOCKED_FAULT_S = 10.0
"""Stopped this long by something ahead (another robot on the line, a person, a trolley) while
following the line: the server is told, as a fault ``blocked``, while it lasts."""


class RobotReport:
    """Builds the data-exchange request (PascalCase, DESIGN.md "Fleet data exchange")."""

    def __init__(self, robot_name: str, wall_clock: WallClock, tracker: BeaconTracker,
                 arrival: Arrival, load: LoadCheck | None, front_range: RangeSensor | None,
                 holding: Callable[[], dict[str, Any] | None] | None = None, *,
                 ctx: RobotContext | None = None, guard: ObstacleGuard | None = None,
                 queue: BaseQueue | None = None,
                 facts: Callable[[], SiteFacts] | None = None) -> None:
        self.robot_name = robot_name
        self.wall_clock = wall_clock
        self.tracker = tracker
        self.arrival = arrival
        self.load = load
        self.front_range = front_range
        self.holding = holding
        self.ctx = ctx
        self.guard = guard
        self.queue = queue
        self.facts = facts

    def build(self) -> dict[str, Any]:
        weight = self.load.weight().kg if self.load is not None else None
        reading = self.front_range.latest() if self.front_range is not None else None
        stamp = self.wall_clock().astimezone(UTC).isoformat().replace("+00:00", "Z")
        queued = self.queue is not None and self.queue.queued
        report: dict[str, Any] = {
            "RobotName": self.robot_name,
            "Timestamp": stamp,
            "DetectedBeacons": self.tracker.detected_beacons(),
            "IsInTarget": self.arrival.is_in_target or queued,
            "Queued": queued,
            "WeightKg": round(weight, 3) if weight is not None else None,
            "UltrasonicDistance": round(reading.distance_cm, 1) if reading is not None else None,
        }
        held = self.holding() if self.holding is not None else None
        if held is not None:
            # An extension of the contract (the server ignores names it does not know): what
            # the robot carries and whose, e.g. after a restart with laundry aboard.
            report["Holding"] = held
        if self.ctx is not None:
            report.update(self.robot_state(self.ctx, queued=queued))
        if self.facts is not None:
            # Added (issue 29): what the site status carries for every robot; no pose on a
            # line, the last room instead.
            fields = site_fields("laundry", self.facts())
            report.update({k: fields[k] for k in ("Profile", "Place", "Job")})
        return report

    def robot_state(self, ctx: RobotContext, *, queued: bool = False) -> dict[str, Any]:
        """Added to the contract (issue 27): the state path, the e-stop, the fault that keeps
        the robot from its job (recovery's, or a block ahead that lasts, unless it is the
        queue at base), the battery."""
        battery = ctx.devices.battery.latest() if ctx.devices.battery is not None else None
        fault = ctx.fault
        shown = {"Code": fault.code, "Message": fault.message} if fault is not None else None
        guard = self.guard
        if shown is None and guard is not None and guard.blocked_since_s is not None \
                and ctx.state in FOLLOWING and not queued:
            blocked_s = ctx.loop_time_s() - guard.blocked_since_s
            if blocked_s >= BLOCKED_FAULT_S:
                shown = {"Code": "blocked",
                         "Message": f"{guard.blocked_why} for {blocked_s:.0f} s"}
        return {
            "State": ctx.state,
            "EmergencyStopActive": ctx.estop_latch.latched,
            "Fault": shown,
            "BatteryPct": round(battery.percent, 1) if battery is not None else None,
        }
