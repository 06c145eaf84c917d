"""The cabinet robot's success conditions and figures, from its events.

``cabinets_in_order``: the ``cabinet.arrived`` events name these cabinets in this order.
``max_arrival_error_m``: each arrival's true position (the runner adds it) within this of the
planned standoff pose. ``min_change_orientation``, ``min_links_closed``, ``min_links_reset``:
at least that many ``fit.change_orientation``, ``link.closed``, ``links.reset`` events (the
robot's own resets: a technician's ``cabinet.reset_links`` is figure ``links_reset_by_hand``).
``mission_failed_naming``: the expected outcome is ``mission.failed`` naming that cabinet, with
the wheels stopped: the run then exits 1 (the robot's mission failed, as the scenario says it
must) with ``mission.failed as expected: <reason>`` as its reason; anything else is named.
"""

from __future__ import annotations

import math
from typing import Any

from sim.slice import CheckRun, Events
from sim.world.body import DiffDriveBody

CABINET_SUCCESS_KEYS = ("cabinets_in_order", "max_arrival_error_m", "min_change_orientation",
                        "min_links_closed", "min_links_reset", "mission_failed_naming")

_COUNTED = {"min_change_orientation": "fit.change_orientation",
            "min_links_closed": "link.closed", "min_links_reset": "links.reset"}


def by_hand(event: dict[str, Any]) -> bool:
    """A technician's reset (``cabinet.reset_links`` on the control socket, ``by="control"``):
    not the robot's own ``reset_links`` case, so counted apart (docs/daemon.md)."""
    return event.get("by") == "control"


def _arrivals(events: list[dict[str, Any]]) -> list[dict[str, Any]]:
    return [e for e in events if e.get("kind") == "cabinet.arrived"]


def arrival_error_m(event: dict[str, Any]) -> float:
    """How far the robot truly stood from the planned standoff pose when it reported."""
    return math.hypot(float(event["x_m"]) - float(event["plan_x_m"]),
                      float(event["y_m"]) - float(event["plan_y_m"]))


def cabinet_failures(extra: dict[str, Any], events: list[dict[str, Any]],
                     bodies: list[DiffDriveBody]) -> list[str]:
    """Every cabinet condition that does not hold, as a sentence."""
    reasons: list[str] = []
    arrivals = _arrivals(events)
    if "cabinets_in_order" in extra:
        want = [str(c) for c in extra["cabinets_in_order"]]
        got = [str(e.get("cabinet")) for e in arrivals]
        if got != want:
            reasons.append(f"arrived at cabinets {got or 'none'}, expected {want} in order")
    if "max_arrival_error_m" in extra:
        limit = float(extra["max_arrival_error_m"])
        for e in arrivals:
            off = arrival_error_m(e)
            if off > limit:
                reasons.append(f"arrived at cabinet {e.get('cabinet')} {off * 100:.1f} cm "
                               f"from its standoff pose, more than {limit * 100:.1f} cm")
    for key, kind in _COUNTED.items():
        if key in extra:
            count = sum(1 for e in events if e.get("kind") == kind and not by_hand(e))
            if count < int(extra[key]):
                reasons.append(f"{count} {kind} event(s), expected at least {extra[key]}")
    if "mission_failed_naming" in extra:
        reasons += _expected_failure(str(extra["mission_failed_naming"]), events, bodies)
    return reasons


def _expected_failure(cabinet: str, events: list[dict[str, Any]],
                      bodies: list[DiffDriveBody]) -> list[str]:
    failed = [e for e in events if e.get("kind") == "mission.failed"]
    if not failed:
        return [f"expected mission.failed naming cabinet {cabinet}, the mission did not fail"]
    event = failed[-1]
    reason = str(event.get("reason", ""))
    if event.get("cabinet") != cabinet or cabinet not in reason:
        return [f"expected mission.failed naming cabinet {cabinet}, got {reason!r}"]
    # Stopped: no wheel power commanded, and the wheels at rest or running down.
    moving = [b for b in bodies if b.pwm[0] or b.pwm[1]]
    if moving:
        return [f"mission.failed naming cabinet {cabinet}, but the wheels are still driven"]
    return [f"mission.failed as expected: {reason}"]


def cabinet_figures(events: list[dict[str, Any]]) -> dict[str, Any]:
    """Arrivals, their worst true error, fits tried, links closed and resets."""
    arrivals = _arrivals(events)
    if not arrivals and not any(e.get("kind") == "fit.tried" for e in events):
        return {}
    out: dict[str, Any] = {
        "cabinets_arrived": len(arrivals),
        "fits_tried": sum(1 for e in events if e.get("kind") == "fit.tried"),
        "links_closed": sum(1 for e in events if e.get("kind") == "link.closed"),
        "links_reset": sum(1 for e in events
                           if e.get("kind") == "links.reset" and not by_hand(e)),
        "links_reset_by_hand": sum(1 for e in events
                                   if e.get("kind") == "links.reset" and by_hand(e)),
    }
    if arrivals:
        out["max_arrival_error_cm"] = round(max(arrival_error_m(e) for e in arrivals) * 100, 2)
    return out


class CabinetCheck:
    """The cabinet robot's conditions (``CABINET_SUCCESS_KEYS``) and figures."""

    keys = CABINET_SUCCESS_KEYS

    def failures(self, run: CheckRun) -> list[str]:
        return cabinet_failures(run.extra, run.events, run.bodies)

    def figures(self, events: Events) -> dict[str, Any]:
        return cabinet_figures(events)
