"""A robot profile: the mission states it nests in the machine, its transitions and its tasks."""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

from behaviours.context import RobotContext
from behaviours.persistence import MissionRecord
from hal.options import Order, Section

if TYPE_CHECKING:
    from behaviours.service import Service

StateTask = Callable[[RobotContext], Awaitable[None]]
"""A long behaviour run while a state is active: started on enter, cancelled on exit."""

ControlMethod = Callable[[dict[str, Any]], Awaitable[Any]]
"""A control-socket method a profile offers (``robotctl``): params -> a JSON-able result.
Raise ValueError for bad params, ``ControlRefused`` when the robot cannot do it now."""


class ControlRefused(Exception):
    """A profile's control method refuses (e.g. not in the state it needs); says why."""

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
    def mission_records(self) -> tuple[MissionRecord, ...]: ...
    def control_methods(self, ctx: RobotContext) -> dict[str, ControlMethod]: ...


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

    def mission_records(self) -> tuple[MissionRecord, ...]:
        """What must survive a restart; restored (``ctx.persisted``) before ``boot`` is left."""
        return ()

    def control_methods(self, ctx: RobotContext) -> dict[str, ControlMethod]:
        """Control-socket methods the profile adds, named ``<profile>.<method>``."""
        return {}


@dataclass(frozen=True, slots=True)
class ProfileSpec:
    """A robot profile as the registry knows it, declared once beside the profile's code.

    The daemon builds ``profile()`` for ``robot.profile = name``; ``check-config`` and
    ``example-config`` know the profile's own config ``sections`` (and the ``orders`` of its
    paired limits) from here, without building anything.
    """

    profile: type[BaseProfile]
    summary: str
    """One line: what the robot does (``robotd sim --help``, the docs)."""
    sections: tuple[Section, ...] = ()
    orders: tuple[Order, ...] = ()
    sim_actors: str | None = None
    """``module:callable`` that builds the simulator's actors for such robots (the people and
    servers around them, under ``robotd/sim/actors/``), or None. A name, not an import:
    behaviours never import robotd; a test resolves every registered one."""

    @property
    def name(self) -> str:
        """The ``robot.profile`` value that selects it."""
        return self.profile.name

    @property
    def devices(self) -> tuple[str, ...]:
        """The ``Devices`` slots it needs."""
        return self.profile.devices
