"""Script actions on a robot's daemon: kill it as SIGKILL would, and start it again."""

from __future__ import annotations

from collections.abc import Awaitable

from sim.actions.step import Action, Step


def _kill(step: Step) -> Awaitable[None] | None:
    if step.daemons is None:
        return None
    return step.daemons.kill(step.robot, step.duration_s())  # down this long, then restarted


def _restart(step: Step) -> Awaitable[None] | None:
    if step.daemons is None:
        return None
    return step.daemons.restart(step.robot)


ROBOT_ACTIONS: dict[str, Action] = {
    "robot.kill": _kill,
    "robot.restart": _restart,
}
