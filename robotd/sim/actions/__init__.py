"""What a scenario's script can do, by action name: one module per thing acted on.

An action is a function of one ``Step`` (the robot's rig, the step's arguments, and
``later()`` for the second half of a fault with a ``duration_s``). A new simulated device
brings its actions in a module here and adds them to ``ACTIONS``.
"""

from __future__ import annotations

from robotd.sim.actions.delivery import DELIVERY_ACTIONS
from robotd.sim.actions.dock import DOCK_ACTIONS
from robotd.sim.actions.doors import DOOR_ACTIONS
from robotd.sim.actions.lidar import LIDAR_ACTIONS
from robotd.sim.actions.motor_board import MOTOR_BOARD_ACTIONS
from robotd.sim.actions.people import PEOPLE_ACTIONS
from robotd.sim.actions.robot import ROBOT_ACTIONS
from robotd.sim.actions.step import Action, Step
from robotd.sim.actions.world import WORLD_ACTIONS

ACTIONS: dict[str, Action] = {
    **DOCK_ACTIONS,
    **MOTOR_BOARD_ACTIONS,
    **WORLD_ACTIONS,
    **ROBOT_ACTIONS,
    **LIDAR_ACTIONS,
    **PEOPLE_ACTIONS,
    **DELIVERY_ACTIONS,
    **DOOR_ACTIONS,
}
"""Action name (``script[i].action``) -> what it does."""

__all__ = ["ACTIONS", "Action", "Step"]
