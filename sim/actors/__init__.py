"""Simulated people and servers around a robot (customers, staff, fleet), per profile.

A profile that has actors names their factory in its simulator slice's ``SimSlice.actors``
(``module:callable``); the runner asks it once per simulation and drives what it returns
through ``SimActors``, with no branch on the profile's name.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Coroutine
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import Any, Protocol

from robotd.config.settings import Settings
from sim.registry import slice_of
from sim.rig import SimRig
from sim.scenario import Scenario

ActorTask = tuple[str, Coroutine[Any, Any, None]]
"""(task name, coroutine) of one actor."""


@dataclass(frozen=True, slots=True)
class ActorContext:
    """What actors get from the runner."""

    scenario: Scenario
    workdir: Path
    """The run's scratch directory (a server's database goes here)."""
    origin: datetime
    """Wall-clock time at virtual t = 0."""
    record: Callable[[dict[str, Any]], None]
    """Records an event in events.jsonl (``{"kind": ..., ...}``)."""
    set_payload: Callable[[str, float], None]
    """Puts ``kg`` in the named robot's bin (a person loading or unloading it)."""
    robot_room: Callable[[str], str | None] = lambda _robot: None
    """The room of the world the named robot stands in now (None: none, or no such robot):
    what a person on the site sees."""
    payload_kg: Callable[[str], float] = lambda _robot: 0.0
    """What lies in the named robot's bin now."""
    robot_state: Callable[[str], str | None] = lambda _robot: None
    """The named robot's state path now (``mission.at_room``), as its daemon last said."""
    fleet_url: str | None = None
    """An outside fleet server the robots report to (``robotd sim --fleet-url``), instead of
    the one the scenario runs in-process: its people are then real ones, in a browser."""
    fleet_token_file: str | None = None
    """The robots' token file for that server (``--fleet-token-file``)."""


class SimActors(Protocol):
    """The actors of one profile in one simulation, in the order the runner calls them."""

    async def start(self) -> None:
        """Before any robot is built (a server the robots talk to must be up first)."""

    def configure_robot(self, settings: Settings) -> None:
        """A robot of the profile, before it is built (e.g. ``fleet.url`` of the server)."""

    def attach(self, rig: SimRig) -> None:
        """Each robot's simulated devices, as they are built (e.g. its network)."""

    def people(self) -> list[ActorTask]:
        """Actors whose work must end before the scenario can (customers)."""

    def background(self) -> list[ActorTask]:
        """Actors that run until the scenario ends (staff)."""

    def failures(self) -> list[str]:
        """After the run: what went wrong in the actors' eyes, one reason each."""

    async def close(self) -> None:
        """After the robots' devices are closed."""


ActorsFactory = Callable[[ActorContext], "SimActors | None"]
"""Builds a profile's actors for a scenario; None when the scenario gives it none."""


def actors_factory(profile: str) -> ActorsFactory | None:
    """The factory the profile's simulator slice names in ``actors`` (imported now: the laundry
    fleet server's imports take seconds, and only simulations need them), or None."""
    named = slice_of(profile).actors
    if named is None:
        return None
    module_name, _, attribute = named.partition(":")
    target: object = importlib.import_module(module_name)
    for part in attribute.split("."):
        target = getattr(target, part)
    if not callable(target):
        msg = f"profile {profile!r}: actors {named!r} is not callable"
        raise TypeError(msg)
    factory: ActorsFactory = target
    return factory
