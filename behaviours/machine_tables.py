"""The robot's root states and transitions as data (``transitions`` dict format).

Callback and condition names refer to methods of ``behaviours.machine.MachineModel`` (or of
the profile, for names in a profile's own tables). State paths are dotted: ``docking.search``.
"""

from __future__ import annotations

from typing import Any

from behaviours.machine_part import MachinePart

RECOVERY_TIMEOUT_S = 120.0

ROOT_STATES = ("boot", "idle", "mission", "docking", "relocate", "recovery", "estop",
               "maintenance")
MOVING_STATES = ["mission", "docking", "relocate", "recovery"]


def root_states(mission_children: list[str | dict[str, Any]],
                parts: tuple[MachinePart, ...] = ()) -> list[dict[str, Any]]:
    """Every root state; the profile's mission states nest under ``mission``, and each part a
    profile plugs in fills its root state (``docking``: the docking capability's phases)."""
    mission: dict[str, Any] = {"name": "mission"}
    if mission_children:
        first = mission_children[0]
        mission["children"] = mission_children
        mission["initial"] = first if isinstance(first, str) else first["name"]
    states: list[dict[str, Any]] = [
        {"name": "boot"},
        {"name": "idle", "on_enter": "stop_motors"},
        mission,
        {"name": "docking"},
        {"name": "relocate"},
        {"name": "recovery", "on_enter": "stop_motors", "timeout": RECOVERY_TIMEOUT_S,
         "on_timeout": "timed_out"},
        {"name": "estop", "on_enter": "stop_motors"},
        {"name": "maintenance", "on_enter": "stop_motors"},
    ]
    by_name = {s["name"]: s for s in states}
    for part in parts:
        if part.root_state not in by_name or part.root_state == "mission":
            msg = f"machine part {part.name!r}: no root state {part.root_state!r} to fill"
            raise ValueError(msg)
        by_name[part.root_state].update(part.state)
    return states


CORE_TRANSITIONS: list[dict[str, Any]] = [
    {"trigger": "booted", "source": "boot", "dest": "idle"},
    {"trigger": "start_mission", "source": "idle", "dest": "mission"},
    {"trigger": "mission_done", "source": "mission", "dest": "idle"},
    {"trigger": "lost", "source": ["idle", "mission"], "dest": "relocate"},
    {"trigger": "relocated", "source": "relocate", "dest": "idle"},
    {"trigger": "fault", "source": ["mission", "docking", "relocate"], "dest": "recovery"},
    {"trigger": "recovered", "source": "recovery", "dest": "idle"},
    {"trigger": "timeout", "source": "recovery", "dest": "estop"},
    {"trigger": "estop", "source": "*", "dest": "estop"},
    {"trigger": "resume", "source": "estop", "dest": "idle"},
    {"trigger": "maintenance", "source": ["idle", *MOVING_STATES], "dest": "maintenance"},
    {"trigger": "end_maintenance", "source": "maintenance", "dest": "idle"},
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
