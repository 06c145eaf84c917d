"""Script actions on a cabinet site's doors: ``door.close`` and ``door.open`` (``name``).

The door is one of the world's JSON map's doors (``[world] site_map``); closing it puts its
segment in the world as a wall the robot's map does not have, opening it takes it out.
"""

from __future__ import annotations

from sim.actions.step import Action, Step
from sim.robots.cabinet.site_world import KEY, close_door, door_segment, open_door, site_map_of
from sim.scenario import ScenarioError, scenario_dir
from sim.world.snag import snag_action


def _door(step: Step, close: bool) -> None:
    scenario = step.scenario
    name = scenario.raw.get("world", {}).get(KEY)
    if not isinstance(name, str):
        msg = f"door.{'close' if close else 'open'}: the world has no {KEY} (no doors)"
        raise ScenarioError(msg)
    site = site_map_of(name, scenario_dir(scenario.source))
    try:
        segment = door_segment(site, str(step.args.get("name", "")))
    except ValueError as exc:
        msg = f"door.{'close' if close else 'open'}: {exc}"
        raise ScenarioError(msg) from None
    world = scenario.world
    if close:
        close_door(world, segment)
    else:
        open_door(world, segment)
    body = step.rig.body
    body.pose = body.pose  # the body checks its way against the walls as they are now


DOOR_ACTIONS: dict[str, Action] = {
    "door.close": lambda step: _door(step, True),
    "door.open": lambda step: _door(step, False),
    "body.snag": snag_action,  # the drive controller's own "cannot reach the node"
}
