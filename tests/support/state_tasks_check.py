"""Whether a profile's state tasks cover its mission's leaf states (issue 26): a leaf with no
task sits until its timeout (or for ever), and a task keyed by anything but a leaf of the table
never starts on the leaf the robot is in."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

from behaviours.machine_tables import RootState, state_paths


def state_task_problems(mission_states: list[Any], tasks: Mapping[str, Any],
                        waiting: Iterable[str] = ()) -> list[str]:
    """What is wrong between the leaves under ``mission`` in ``mission_states`` and the
    ``mission.*`` keys of ``tasks``; ``waiting``: leaves that wait for a trigger from outside
    (a person, the fleet) and have no task on purpose."""
    leaves = state_paths(mission_states, RootState.MISSION, leaves_only=True)
    waiting = set(waiting)
    problems = [f"{leaf}: no state task" for leaf in leaves
                if leaf not in waiting and not callable(tasks.get(leaf))]
    problems += [f"{leaf}: waits, but is no leaf of the table" for leaf in sorted(waiting)
                 if leaf not in leaves]
    problems += [f"{key}: a task for no leaf of the mission" for key in tasks
                 if key.startswith(RootState.MISSION + ".") and key not in leaves]
    return problems
