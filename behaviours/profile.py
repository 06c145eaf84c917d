"""A robot profile: the mission states it nests in the machine, its transitions and its tasks."""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

from behaviours.context import Fault, RobotContext
from behaviours.machine_part import MachinePart
from behaviours.persistence import MissionRecord
from hal.options import FileCheck, Order, Section

if TYPE_CHECKING:
    from behaviours.service import Service

StateTask = Callable[[RobotContext], Awaitable[None]]
"""A long behaviour run while a state is active: started on enter, cancelled on exit."""

ControlMethod = Callable[[dict[str, Any]], Awaitable[Any]]
"""A control-socket method a profile offers (``robotctl``): params -> a JSON-able result.
Raise ValueError for bad params, ``ControlRefused`` when the robot cannot do it now."""


Table = Callable[[list[str], list[list[Any]]], str]
"""robotctl's table maker: ``table(headers, rows) -> text``."""


@dataclass(frozen=True, slots=True)
class CtlOption:
    """An option of a profile's ``robotctl`` command: ``--by NAME`` -> params ``{"by": ...}``."""

    flag: str
    default: str
    help: str

    @property
    def param(self) -> str:
        return self.flag.lstrip("-").replace("-", "_")


@dataclass(frozen=True, slots=True)
class CtlCommand:
    """A ``robotctl`` command a profile brings: it calls the control method ``method`` (one of
    the profile's ``control_methods``) with its options as params."""

    name: str
    help: str
    method: str
    options: tuple[CtlOption, ...] = ()
    render: Callable[[Any, Table], str] | None = None
    """The result as text (None: robotctl's key/value table)."""


@dataclass(frozen=True, slots=True)
class SiteFacts:
    """What a profile says of where it is and what it is doing, for whoever shows the site
    (the fleet server's robot list). Every field may be None: not known, or not its kind.

    Args:
        x_m, y_m, theta_rad: the pose in the frame ``map_name`` names (a LiDAR robot's site
            map; ``odom`` for a robot that knows only where it started).
        map_name: the map (file stem) of that pose.
        place: the last room or beacon heard, for a robot on a line.
        job: what it serves now: a request, an order, a cabinet task (one short line).
        fault: a fault the profile's own states hold (the machine's ``recovery`` is the
            context's ``fault``, reported without this).
    """

    x_m: float | None = None
    y_m: float | None = None
    theta_rad: float | None = None
    map_name: str | None = None
    place: str | None = None
    job: str | None = None
    fault: Fault | None = None


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
    def machine_parts(self, ctx: RobotContext) -> tuple[MachinePart, ...]: ...
    def site_facts(self, ctx: RobotContext) -> SiteFacts: ...
    @property
    def reports_itself(self) -> bool: ...


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

    def machine_parts(self, ctx: RobotContext) -> tuple[MachinePart, ...]:
        """The capabilities it plugs into the machine (docking: ``Docking.machine_part``)."""
        return ()

    def site_facts(self, ctx: RobotContext) -> SiteFacts:
        """Where the robot is and what job it does, read (short, no waiting) each time the
        robot reports to a site server; nothing known by default."""
        return SiteFacts()

    @property
    def reports_itself(self) -> bool:
        """True when the profile's own services tell the fleet server (``fleet.url``) all a
        site report would (the laundry data exchange): the daemon then adds none."""
        return False


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
    file_checks: tuple[FileCheck, ...] = ()
    """Checks of the files its config points to (maps, task lists, databases), run by
    ``check-config`` and before the daemon starts."""
    commands: tuple[CtlCommand, ...] = ()
    """The ``robotctl`` commands it adds (each calls one of its control methods)."""
    sim: str | None = None
    """The module of its simulator slice (``SIM``, a ``sim.slice.SimSlice``), or None for
    ``sim.robots.<name>`` when that exists. A name, not an import: behaviours never import
    the simulator."""

    @property
    def name(self) -> str:
        """The ``robot.profile`` value that selects it."""
        return self.profile.name

    @property
    def devices(self) -> tuple[str, ...]:
        """The ``Devices`` slots it needs."""
        return self.profile.devices
