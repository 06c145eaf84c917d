"""Script actions on the world and the robot's settings: payload, people, settings."""

from __future__ import annotations

from sim.actions.step import Action, Step
from sim.scenario import ScenarioError


def _payload(step: Step) -> None:
    step.rig.body.payload_kg = float(step.args.get("kg", 0.0))


def _person(step: Step, present: bool) -> None:
    args = step.args
    name = str(args.get("name", ""))
    for person in step.scenario.world.people:
        if person.name == name:
            person.present = present
            if "x_m" in args:
                person.x_m = float(args["x_m"])
            if "y_m" in args:
                person.y_m = float(args["y_m"])
            return
    msg = f"no person named {name!r}"
    raise ScenarioError(msg)


def _settings(step: Step) -> None:
    step.rig.settings.set(str(step.args["key"]), step.args["value"])


WORLD_ACTIONS: dict[str, Action] = {
    "payload.set": _payload,
    "person.place": lambda step: _person(step, True),
    "person.remove": lambda step: _person(step, False),
    "settings.set": _settings,
}
