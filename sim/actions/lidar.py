"""Script actions on a robot's simulated LD19: unplug, corrupt, stall (and their ends)."""

from __future__ import annotations

from sim.actions.step import Action, Step
from sim.devices.ld19 import SimLd19
from sim.scenario import ScenarioError


def _ld19(step: Step) -> SimLd19:
    ld19 = step.rig.ld19
    if ld19 is None:
        msg = f"{step.robot} has no LiDAR (its profile does not use one)"
        raise ScenarioError(msg)
    return ld19


def _unplug(step: Step) -> None:
    """The USB cable pulled; ``duration_s``: plugged back in after that long."""
    _ld19(step).unplug(step.duration_s())


def _corrupt(step: Step) -> None:
    """One bit flipped in ``pct`` % of the bytes; ``duration_s``: clean again after it."""
    ld19 = _ld19(step)
    ld19.corrupt(float(step.args.get("pct", 2.0)))
    duration = step.duration_s()
    if duration is not None:
        step.later(duration, lambda: ld19.corrupt(0.0), "lidar.corrupt_end")


def _stall(step: Step) -> None:
    """The motor stops: the port open and silent; ``duration_s``: it spins up again."""
    ld19 = _ld19(step)
    ld19.stall(True)
    duration = step.duration_s()
    if duration is not None:
        step.later(duration, lambda: ld19.stall(False), "lidar.stall_end")


LIDAR_ACTIONS: dict[str, Action] = {
    "lidar.unplug": _unplug,
    "lidar.replug": lambda step: _ld19(step).replug(),
    "lidar.corrupt": _corrupt,
    "lidar.stall": _stall,
}
