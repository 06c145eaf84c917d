"""The robot's root states and transitions as data (``transitions`` dict format).

Callback and condition names refer to methods of ``behaviours.machine.MachineModel`` (or of
the profile, for names in a profile's own tables). State paths are dotted: ``docking.search``.
"""

from __future__ import annotations

from typing import Any, Final

from behaviours.machine_part import MachinePart

RECOVERY_TIMEOUT_S = 120.0


class RootState:
    """The root states' names, as they appear in logs, events and on the control socket.

    Plain ``str`` constants, not an Enum: ``transitions`` takes an Enum state by its member
    name (``IDLE``), not its value, and would rename every state.
    """

    BOOT: Final = "boot"
    IDLE: Final = "idle"
    MISSION: Final = "mission"
    DOCKING: Final = "docking"
    RELOCATE: Final = "relocate"
    RECOVERY: Final = "recovery"
    ESTOP: Final = "estop"
    MAINTENANCE: Final = "maintenance"


class CoreTrigger:
    """The triggers of the core transitions (every robot has them)."""

    BOOTED: Final = "booted"
    START_MISSION: Final = "start_mission"
    MISSION_DONE: Final = "mission_done"
    LOST: Final = "lost"
    RELOCATED: Final = "relocated"
    FAULT: Final = "fault"
    RECOVERED: Final = "recovered"
    TIMEOUT: Final = "timeout"
    """Fired by a state's own timeout (``timed_out``); a profile's tables may take it too."""
    ESTOP: Final = "estop"
    RESUME: Final = "resume"
    MAINTENANCE: Final = "maintenance"
    END_MAINTENANCE: Final = "end_maintenance"


S, T = RootState, CoreTrigger
ROOT_STATES = (S.BOOT, S.IDLE, S.MISSION, S.DOCKING, S.RELOCATE, S.RECOVERY, S.ESTOP,
               S.MAINTENANCE)
MOVING_STATES = [S.MISSION, S.DOCKING, S.RELOCATE, S.RECOVERY]


def root_states(mission_children: list[str | dict[str, Any]],
                parts: tuple[MachinePart, ...] = ()) -> list[dict[str, Any]]:
    """Every root state; the profile's mission states nest under ``mission``, and each part a
    profile plugs in fills its root state (``docking``: the docking capability's phases)."""
    mission: dict[str, Any] = {"name": S.MISSION}
    if mission_children:
        first = mission_children[0]
        mission["children"] = mission_children
        mission["initial"] = first if isinstance(first, str) else first["name"]
    states: list[dict[str, Any]] = [
        {"name": S.BOOT},
        {"name": S.IDLE, "on_enter": "stop_motors"},
        mission,
        {"name": S.DOCKING},
        {"name": S.RELOCATE},
        {"name": S.RECOVERY, "on_enter": "stop_motors", "timeout": RECOVERY_TIMEOUT_S,
         "on_timeout": "timed_out"},
        {"name": S.ESTOP, "on_enter": "stop_motors"},
        {"name": S.MAINTENANCE, "on_enter": "stop_motors"},
    ]
    by_name = {s["name"]: s for s in states}
    for part in parts:
        if part.root_state not in by_name or part.root_state == S.MISSION:
            msg = f"machine part {part.name!r}: no root state {part.root_state!r} to fill"
            raise ValueError(msg)
        by_name[part.root_state].update(part.state)
    return states


def mission_children(*paths: str) -> list[str | dict[str, Any]]:
    """The names, under ``mission``, of states given by their paths (``mission.plan`` ->
    ``plan``): a profile names its states by path everywhere else."""
    names: list[str | dict[str, Any]] = []
    for path in paths:
        parent, _, name = path.rpartition(".")
        if parent != S.MISSION:
            msg = f"{path!r} is not a state directly under {S.MISSION!r}"
            raise ValueError(msg)
        names.append(name)
    return names


CORE_TRANSITIONS: list[dict[str, Any]] = [
    {"trigger": T.BOOTED, "source": S.BOOT, "dest": S.IDLE},
    {"trigger": T.START_MISSION, "source": S.IDLE, "dest": S.MISSION},
    {"trigger": T.MISSION_DONE, "source": S.MISSION, "dest": S.IDLE},
    {"trigger": T.LOST, "source": [S.IDLE, S.MISSION], "dest": S.RELOCATE},
    {"trigger": T.RELOCATED, "source": S.RELOCATE, "dest": S.IDLE},
    {"trigger": T.FAULT, "source": [S.MISSION, S.DOCKING, S.RELOCATE], "dest": S.RECOVERY},
    {"trigger": T.RECOVERED, "source": S.RECOVERY, "dest": S.IDLE},
    {"trigger": T.TIMEOUT, "source": S.RECOVERY, "dest": S.ESTOP},
    {"trigger": T.ESTOP, "source": "*", "dest": S.ESTOP},
    {"trigger": T.RESUME, "source": S.ESTOP, "dest": S.IDLE},
    {"trigger": T.MAINTENANCE, "source": [S.IDLE, *MOVING_STATES], "dest": S.MAINTENANCE},
    {"trigger": T.END_MAINTENANCE, "source": S.MAINTENANCE, "dest": S.IDLE},
]

CALLBACK_KEYS = ("on_enter", "on_exit", "on_timeout", "before", "after", "prepare",
                 "conditions", "unless")


def callback_names(states: list[Any], transitions: list[dict[str, Any]]) -> set[str]:
    """Every callback or condition named (as a string) in state and transition tables."""
    names: set[str] = set()

    def collect(entry: dict[str, Any]) -> None:
        for key in CALLBACK_KEYS:
            value = entry.get(key)
            for item in value if isinstance(value, list | tuple) else [value]:
                if isinstance(item, str):
                    names.add(item)

    def walk(items: list[Any]) -> None:
        for item in items:
            if isinstance(item, dict):
                collect(item)
                walk(item.get("children", []))

    walk(states)
    for transition in transitions:
        collect(transition)
    return names


def state_paths(states: list[Any], prefix: str = "", *, leaves_only: bool = False) -> list[str]:
    """The dotted path of every state in a states table (children after their parent), under
    ``prefix``; ``leaves_only``: only the states without children."""
    paths: list[str] = []
    for item in states:
        name = item if isinstance(item, str) else item["name"]
        path = f"{prefix}.{name}" if prefix else name
        children = [] if isinstance(item, str) else item.get("children", [])
        if not (leaves_only and children):
            paths.append(path)
        paths += state_paths(children, path, leaves_only=leaves_only)
    return paths
