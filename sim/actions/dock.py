"""Script actions on the dock, the battery and the dock IR receivers: battery level, beams off,
contacts fault, move; receivers unplugged and plugged back in.

The dock belongs to the world (every robot sees the same one); ``battery.set`` and the
receivers act on the step's robot.
"""

from __future__ import annotations

import math

from sim.actions.step import Action, Step
from sim.devices.dock_ir_model import SimDockIr
from sim.scenario import ScenarioError
from sim.world.dock import Dock


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


def _receivers(step: Step, action: str) -> tuple[SimDockIr, tuple[str, ...] | None]:
    """The robot's simulated receivers and the ones named by ``receiver`` (a name or a list;
    None: all of them)."""
    source = step.rig.dock_ir
    if source is None:
        msg = f"{action}: {step.robot} has no dock IR receivers (its profile does not dock)"
        raise ScenarioError(msg)
    value = step.args.get("receiver")
    if value is None:
        return source, None
    names = (value,) if isinstance(value, str) else value
    fitted = {m.name for m in source.mounts}
    if not isinstance(names, list | tuple) or not names \
            or any(not isinstance(n, str) or n not in fitted for n in names):
        msg = f"{action}.receiver: expected one of {sorted(fitted)} or a list of them, " \
              f"got {value!r}"
        raise ScenarioError(msg)
    return source, tuple(names)


def _ir_unplug(step: Step) -> None:
    """The receivers' cable pulled: their lines go idle, no edges (``receiver``: which ones,
    default all); ``duration_s``: plugged back in after that long."""
    source, names = _receivers(step, "dock_ir.unplug")
    source.unplug(names)
    duration = step.duration_s()
    if duration is not None:
        step.later(duration, lambda: source.replug(names), "dock_ir.replug")


def _ir_replug(step: Step) -> None:
    source, names = _receivers(step, "dock_ir.replug")
    source.replug(names)


DOCK_ACTIONS: dict[str, Action] = {
    "battery.set": _battery_set,
    "dock.beams_off": _beams_off,
    "dock.contacts_fault": _contacts_fault,
    "dock.move": _move,
    "dock_ir.unplug": _ir_unplug,
    "dock_ir.replug": _ir_replug,
}
