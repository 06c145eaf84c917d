"""A robot profile: the mission states it nests in the machine, its transitions and its tasks."""

from __future__ import annotations

import importlib
from collections.abc import Awaitable, Callable
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

from behaviours.context import RobotContext

if TYPE_CHECKING:
    from robotd.supervisor import Service

StateTask = Callable[[RobotContext], Awaitable[None]]
"""A long behaviour run while a state is active: started on enter, cancelled on exit."""

PROFILES: dict[str, str] = {
    "idle": "behaviours.profile:IdleProfile",
    "square": "behaviours.profiles.square.profile:SquareProfile",
    "laundry": "behaviours.profiles.laundry.profile:LaundryProfile",
}
"""Profile name (``robot.profile``) -> ``module:Class``; the class is built with no arguments."""


@runtime_checkable
class Profile(Protocol):
    """What the daemon asks of a robot profile.

    State names inside ``mission_states`` are relative to ``mission``; everywhere else
    (transitions, ``state_tasks``, hooks) states are dotted paths such as ``mission.drive`` or
    ``docking.approach``. Transitions use the ``transitions`` dict format.
    """

    name: str
    devices: tuple[str, ...]
    """The ``Devices`` slots the profile needs (``motors``, ``camera`` ...)."""

    def mission_states(self) -> list[str | dict[str, Any]]: ...
    def mission_transitions(self) -> list[dict[str, Any]]: ...
    def services(self, ctx: RobotContext) -> list[Service]: ...
    def state_tasks(self) -> dict[str, StateTask]: ...
    def on_enter(self, state: str, ctx: RobotContext) -> None: ...
    def on_exit(self, state: str, ctx: RobotContext) -> None: ...


class BaseProfile:
    """Defaults for every part of ``Profile``; a profile overrides what it uses."""

    name = "base"
    devices: tuple[str, ...] = ()

    def mission_states(self) -> list[str | dict[str, Any]]:
        return []

    def mission_transitions(self) -> list[dict[str, Any]]:
        return []

    def services(self, ctx: RobotContext) -> list[Service]:
        return []

    def state_tasks(self) -> dict[str, StateTask]:
        """State path -> task; the task runs while that state (or one inside it) is active."""
        return {}

    def on_enter(self, state: str, ctx: RobotContext) -> None:
        """Called (short, no waiting) whenever ``state`` is entered."""

    def on_exit(self, state: str, ctx: RobotContext) -> None:
        """Called (short, no waiting) whenever ``state`` is left."""


class IdleProfile(BaseProfile):
    """A robot that needs no hardware and has no mission: boots, idles, obeys estop/resume."""

    name = "idle"


def load_profile(name: str) -> Profile:
    """Build the profile registered as ``name``; ValueError with the known names otherwise."""
    target = PROFILES.get(name)
    if target is None:
        msg = f"robot.profile: unknown profile {name!r} (known: {', '.join(sorted(PROFILES))})"
        raise ValueError(msg)
    module_name, _, class_name = target.partition(":")
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        msg = f"robot.profile: profile {name!r} cannot be loaded: {exc}"
        raise ValueError(msg) from exc
    profile: Profile = getattr(module, class_name)()
    return profile
