"""``survey.handover``: the survey saved its map; the robot restarts as a profile that drives
on it (the patrol), from where the survey left it.

A script step (``when_state = "idle"`` after the exploring mission) names the profile
(``name``); the map is the one the survey's last ``mapping.saved`` event wrote, and the pose
the new profile starts from is the survey's last estimate (the map's frame is the survey's).
It is what a
technician does on a real robot: ``robotctl map save depot``, set ``map.file`` and
``robot.profile`` in the config, restart, ``robotctl pose set`` where the robot stands.
"""

from __future__ import annotations

from collections.abc import Awaitable
from typing import Any

from sim.actions.step import Action, Step
from sim.robots.survey.checks import map_figures


def _handover(step: Step) -> Awaitable[None] | None:
    daemons = step.daemons
    if daemons is None:
        return None
    robot = daemons.robots[step.robot]
    saved = [e for e in robot.daemon.events if e.get("kind") == "mapping.saved"]
    if not saved:
        msg = "survey.handover: the survey saved no map (no mapping.saved event)"
        raise RuntimeError(msg)
    last: dict[str, Any] = saved[-1]
    true_map = step.scenario.world.map_source
    if true_map:  # judged now: the map lives in the run's temporary state directory
        robot.daemon.emit("mapping.judged", yaml=last["yaml"],
                          **map_figures(list(robot.daemon.events), true_map))
    x, y, heading = last["pose"]
    changes: dict[str, Any] = {
        "robot.profile": str(step.args.get("name", "patrol")),
        "map.file": last["yaml"],
        "localisation.initial_pose": "config",
        "localisation.initial_x_m": x, "localisation.initial_y_m": y,
        "localisation.initial_heading_deg": heading,
    }
    return daemons.replace(step.robot, changes)


HANDOVER_ACTIONS: dict[str, Action] = {"survey.handover": _handover}
