"""A robot's simulator slice, as the simulator's registry knows it (``SimSlice``).

A profile's runtime slice (``behaviours/profiles/<name>/``) is paired with a simulator slice,
by default the package ``sim.robots.<name>`` (``ProfileSpec.sim`` names another), whose
``SIM`` is a ``SimSlice``: its scenarios, the people and servers around it, its success checks,
its report layers, its script actions, the devices only it has and the world parts only its
scenarios draw. The runner, the checks, the report and the scenario loader iterate over these
and name no robot (``sim.registry``).
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

if TYPE_CHECKING:
    from hal.backend import Devices
    from robotd.config.settings import Settings
    from sim.world.body import DiffDriveBody
    from sim.world.floor_plan import World

Events = list[dict[str, Any]]


@dataclass(frozen=True, slots=True)
class CheckRun:
    """What a success check reads after a run."""

    extra: dict[str, Any]
    """The scenario's ``[success]`` keys beyond the common ones."""
    events: Events
    config: dict[str, dict[str, Any]]
    """The scenario's ``[config]`` tables."""
    bodies: list[DiffDriveBody]
    paced: bool
    """The run followed the wall clock, so its timers may be a little late."""


class SuccessCheck(Protocol):
    """Success conditions of one kind (``keys`` in a scenario's ``[success]``)."""

    @property
    def keys(self) -> tuple[str, ...]:
        """The ``[success]`` keys it reads."""

    def failures(self, run: CheckRun) -> list[str]:
        """Each condition that does not hold, as a sentence."""

    def figures(self, events: Events) -> dict[str, Any]:
        """Figures for the summary (one robot's events)."""


ReportLayer = Callable[[Any, "World", Events], None]
"""Draws on the trajectory plot's axes: ``layer(ax, world, events)``."""

DeviceFitter = Callable[["Devices", "World", "DiffDriveBody", "Settings", tuple[str, ...], int],
                        None]
"""Fits the simulated devices only this robot has: ``fit(devices, world, body, settings,
needs, seed)``."""

ScriptAction = Callable[[Any], Awaitable[None] | None]
"""A script action (``sim.actions``): ``action(step)`` with the step a ``sim.actions.Step``
(typed loosely here: the actions know the rig and the scenario, which know the slices)."""

WorldPart = Callable[[dict[str, Any], Path | None], dict[str, Any]]
"""Expands a scenario's ``[world]`` table (a key only this robot's scenarios use) into the
floor plan's own keys: ``part(table, base_dir) -> table``."""


@dataclass(frozen=True, slots=True)
class SimSlice:
    """A robot's simulator slice.

    ``actors`` is a ``module:callable`` name, not an import: the laundry fleet server's
    imports take seconds, and only a simulation of such robots needs them.
    """

    scenarios: str | None = "scenarios"
    """The folder of its built-in scenarios, beside the slice's package (None: none)."""
    actors: str | None = None
    checks: tuple[SuccessCheck, ...] = ()
    layers: tuple[ReportLayer, ...] = ()
    actions: Mapping[str, ScriptAction] = field(default_factory=dict)
    fit_devices: DeviceFitter | None = None
    world_parts: tuple[WorldPart, ...] = ()
    scenario_files: tuple[str, ...] = ()
    """Config keys naming files that a scenario gives relative to itself."""
    scenario_tables: Mapping[str, tuple[str, ...] | None] = field(default_factory=dict)
    """Top-level tables of a scenario that only its actors read: name -> their keys (None:
    the actors check them themselves)."""
    runs_fleet: bool = False
    """Its actors run the fleet server of a scenario's ``[fleet]`` table themselves (the
    laundry site's); otherwise its robots report to the simulator's site fleet
    (``sim.actors.site_fleet``) when the scenario has one."""
