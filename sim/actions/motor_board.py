"""Script actions on a robot's motor board: unplug, replug, corrupt, reset, frozen encoders."""

from __future__ import annotations

from sim.actions.step import Action, Step


def _unplug(step: Step) -> None:
    step.rig.unplug_mcu()
    duration = step.duration_s()
    if duration is not None:
        step.later(duration, step.rig.replug_mcu, "mcu.replug")


def _replug(step: Step) -> None:
    step.rig.replug_mcu()


def _corrupt(step: Step) -> None:
    rig = step.rig
    rig.corrupt_mcu(float(step.args.get("pct", 2.0)))
    duration = step.duration_s()
    if duration is not None:
        step.later(duration, lambda: rig.corrupt_mcu(0.0), "mcu.corrupt_end")


def _reset(step: Step) -> None:
    step.rig.reset_mcu()


def _encoders_fail(step: Step) -> None:
    """``encoders.fail``: the board's encoder counters stop (the wheels still turn);
    ``duration_s``: they run again after that long."""
    rig = step.rig
    rig.freeze_encoders(True)
    duration = step.duration_s()
    if duration is not None:
        step.later(duration, lambda: rig.freeze_encoders(False), "encoders.restore")


def _encoders_restore(step: Step) -> None:
    step.rig.freeze_encoders(False)


MOTOR_BOARD_ACTIONS: dict[str, Action] = {
    "encoders.fail": _encoders_fail,
    "encoders.restore": _encoders_restore,
    "mcu.unplug": _unplug,
    "mcu.replug": _replug,
    "mcu.corrupt": _corrupt,
    "mcu.reset": _reset,
}
