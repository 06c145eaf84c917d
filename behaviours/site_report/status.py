"""The site status report's body (``POST /api/Robot/{RobotName}/status``, docs/fleet.md)."""

from __future__ import annotations

from datetime import UTC
from typing import Any

from behaviours.context import Fault, RobotContext
from behaviours.profile import SiteFacts

_TEXT_MAX = {"Job": 200, "Place": 100, "Map": 100}
"""What the server's columns hold: longer text is cut, not refused."""


def pose_of(facts: SiteFacts) -> dict[str, Any] | None:
    """``Pose`` (``X``, ``Y`` in metres, ``Theta`` in radians, ``Map``), or None when the
    profile gave no full pose."""
    if facts.x_m is None or facts.y_m is None or facts.theta_rad is None:
        return None
    return {"X": round(facts.x_m, 3), "Y": round(facts.y_m, 3),
            "Theta": round(facts.theta_rad, 4), "Map": _cut("Map", facts.map_name)}


def fault_of(ctx: RobotContext, facts: SiteFacts) -> Fault | None:
    """The fault that keeps the robot from its job: the machine's (recovery) first, else the
    one the profile's own states hold."""
    return ctx.fault or facts.fault


def site_fields(profile: str, facts: SiteFacts) -> dict[str, Any]:
    """What a site report adds to what a robot says of itself: ``Profile``, ``Pose``,
    ``Place``, ``Job``."""
    return {"Profile": profile, "Pose": pose_of(facts), "Place": _cut("Place", facts.place),
            "Job": _cut("Job", facts.job)}


def status_body(ctx: RobotContext, profile: str, facts: SiteFacts) -> dict[str, Any]:
    """The whole report: name, time, profile, state path, e-stop latch, fault, battery,
    pose or place, job."""
    battery = ctx.devices.battery.latest() if ctx.devices.battery is not None else None
    fault = fault_of(ctx, facts)
    stamp = ctx.wall_clock().astimezone(UTC).isoformat().replace("+00:00", "Z")
    return {
        "RobotName": str(ctx.settings.get("robot.name")),
        "Timestamp": stamp,
        "State": ctx.state,
        "EmergencyStopActive": ctx.estop_latch.latched,
        "Fault": None if fault is None else {"Code": fault.code[:60],
                                             "Message": fault.message[:500]},
        "BatteryPct": round(min(100.0, max(0.0, battery.percent)), 1)
        if battery is not None else None,
        **site_fields(profile, facts),
    }


def _cut(key: str, text: str | None) -> str | None:
    return None if text is None else text[:_TEXT_MAX[key]]
