"""What a scenario's script can do, by action name: one module per thing acted on.

An action is a function of one ``Step`` (the robot's rig, the step's arguments, and
``later()`` for the second half of a fault with a ``duration_s``). A new simulated device
brings its actions in a module here and adds them to ``ACTIONS``; what only one robot's
scenarios do is in its simulator slice (``SimSlice.actions``), and ``script_actions`` has both.
"""

from __future__ import annotations

from sim.actions.dock import DOCK_ACTIONS
from sim.actions.lidar import LIDAR_ACTIONS
from sim.actions.motor_board import MOTOR_BOARD_ACTIONS
from sim.actions.people import PEOPLE_ACTIONS
from sim.actions.robot import ROBOT_ACTIONS
from sim.actions.step import Action, Step
from sim.actions.world import WORLD_ACTIONS

ACTIONS: dict[str, Action] = {
    **DOCK_ACTIONS,
    **MOTOR_BOARD_ACTIONS,
    **WORLD_ACTIONS,
    **ROBOT_ACTIONS,
    **LIDAR_ACTIONS,
    **PEOPLE_ACTIONS,
}
"""Action name (``script[i].action``) -> what it does, for every robot."""


def script_actions() -> dict[str, Action]:
    """Every action a script may name: the common ones and each robot slice's own."""
    from sim.registry import slices

    merged = dict(ACTIONS)
    for sim in slices():
        merged.update(sim.actions)
    return merged

__all__ = ["ACTIONS", "Action", "Step", "script_actions"]
