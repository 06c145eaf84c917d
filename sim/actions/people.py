"""Script actions that move things in the world: people walking, the robot kidnapped."""

from __future__ import annotations

import asyncio
import math

from sim.actions.step import Action, Step
from sim.scenario import ScenarioError
from sim.world.floor_plan import Person
from sim.world.geometry import Pose
from sim.world.walkers import Walk


def _person(step: Step) -> Person:
    name = str(step.args.get("name", ""))
    for person in step.scenario.world.people:
        if person.name == name:
            return person
    msg = f"no person named {name!r}"
    raise ScenarioError(msg)


def _walk(step: Step) -> None:
    """``person.walk``: ``name`` walks ``points`` ([[x, y], ...], from where the person
    stands) at ``speed_mps`` (default 1.0), once or round and round (``loop``)."""
    person = _person(step)
    raw = step.args.get("points")
    if not isinstance(raw, list) or not raw or not all(
            isinstance(p, list) and len(p) == 2 for p in raw):
        msg = "person.walk: points: expected a list of [x, y] points"
        raise ScenarioError(msg)
    points = ((person.x_m, person.y_m), *((float(p[0]), float(p[1])) for p in raw))
    try:
        person.walk = Walk(points, float(step.args.get("speed_mps", 1.0)),
                           asyncio.get_running_loop().time(),
                           bool(step.args.get("loop", False)))
    except ValueError as exc:
        msg = f"person.walk: {exc}"
        raise ScenarioError(msg) from exc
    person.present = True


def _stop(step: Step) -> None:
    """``person.stop``: the person stands where the walk has got to."""
    person = _person(step)
    person.update(asyncio.get_running_loop().time())
    person.walk = None


def _teleport(step: Step) -> None:
    """``body.teleport``: the robot lifted and put down at (``x_m``, ``y_m``), or moved by
    (``dx_m``, ``dy_m``), facing ``heading_deg`` (default: as it was); its wheels' odometry
    sees nothing of it (the kidnapped robot problem)."""
    body = step.rig.body
    now = body.pose
    args = step.args
    heading = math.radians(float(args["heading_deg"])) if "heading_deg" in args \
        else now.heading_rad
    x = float(args.get("x_m", now.x_m)) + float(args.get("dx_m", 0.0))
    y = float(args.get("y_m", now.y_m)) + float(args.get("dy_m", 0.0))
    body.pose = Pose(x, y, heading)


PEOPLE_ACTIONS: dict[str, Action] = {
    "person.walk": _walk,
    "person.stop": _stop,
    "body.teleport": _teleport,
}
