"""A capability's share of the robot's machine, plugged in by the profiles that use it.

The framework's tables (``machine_tables``) hold the root states and the transitions every
robot has; a capability such as docking fills a root state with its own children, adds its
transitions, and brings the object whose methods those tables name (as Nav2's docking server
takes a dock plugin). A profile hands its parts to the machine (``Profile.machine_parts``);
the framework names none of them.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any


@dataclass(frozen=True, slots=True)
class MachinePart:
    """What one capability adds to the machine.

    Args:
        name: the capability (``docking``), for logs and errors.
        root_state: the root state it fills.
        state: that root state's own keys (``children``, ``initial``, ``on_enter`` ...).
        transitions: its transitions, in the ``transitions`` dict format.
        callbacks: the object whose methods the part's tables name (each takes the event).
    """

    name: str
    root_state: str
    state: dict[str, Any] = field(default_factory=dict)
    transitions: tuple[dict[str, Any], ...] = ()
    callbacks: object = None
