"""Script actions on the dock and the battery: battery level, beams off, contacts fault, move.

The dock belongs to the world (every robot sees the same one); ``battery.set`` acts on the
step's robot.
"""

from __future__ import annotations

import math

from hal.sim.world.dock import Dock
from robotd.sim.actions.step import Action, Step
from robotd.sim.scenario import ScenarioError


def _dock(step: Step, action: str) -> Dock:
    dock = step.scenario.world.dock
    if dock is None:
        msg = f"{action}: the world has no dock (add a [world.dock] table)"
        raise ScenarioError(msg)
    return dock


def _number(step: Step, action: str, key: str, default: float | None = None) -> float:
    value = step.args.get(key, default)
    if isinstance(value, bool) or not isinstance(value, int | float):
        msg = f"{action}.{key}: expected a number, got {value!r}"
        raise ScenarioError(msg)
    return float(value)


def _battery_set(step: Step) -> None:
    pct = _number(step, "battery.set", "pct")
    if not 0 <= pct <= 100:
        msg = f"battery.set.pct: expected 0-100, got {pct}"
        raise ScenarioError(msg)
    body = step.rig.body
    body.sync()
    body.charge_pct = pct


def _beams_off(step: Step) -> None:
    dock = _dock(step, "dock.beams_off")
    dock.emitting = False
    duration = step.duration_s()
    if duration is not None:
        step.later(duration, lambda: setattr(dock, "emitting", True), "dock.beams_on")


def _contacts_fault(step: Step) -> None:
    dock = _dock(step, "dock.contacts_fault")
    step.rig.body.sync()  # charge up to now at the good voltage
    dock.contacts_fault = True
    duration = step.duration_s()
    if duration is not None:
        def mend() -> None:
            step.rig.body.sync()
            dock.contacts_fault = False

        step.later(duration, mend, "dock.contacts_ok")


def _move(step: Step) -> None:
    dock = _dock(step, "dock.move")
    heading_deg = _number(step, "dock.move", "heading_deg", math.degrees(dock.heading_rad))
    step.rig.body.sync()
    dock.move(_number(step, "dock.move", "x_m"), _number(step, "dock.move", "y_m"),
              math.radians(heading_deg))


DOCK_ACTIONS: dict[str, Action] = {
    "battery.set": _battery_set,
    "dock.beams_off": _beams_off,
    "dock.contacts_fault": _contacts_fault,
    "dock.move": _move,
}
