"""The one registry of robot profiles: what ``robot.profile`` may name, and what each brings.

Each profile declares itself beside its code (``behaviours/profiles/<name>/__init__.py``:
``SPEC``, with its devices and config sections); an entry here adds it, with the simulator's
actors for it (the people and servers around such a robot) when it has any. ``check-config``,
``example-config``, ``robotd sim`` and the daemon all read this registry.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING

from behaviours.profile import Profile, ProfileSpec
from behaviours.profiles import idle, laundry, square
from hal.options import Order, Section

if TYPE_CHECKING:
    from robotd.sim.actors import ActorsFactory


@dataclass(frozen=True, slots=True)
class Registered:
    spec: ProfileSpec
    actors: Callable[[], ActorsFactory] | None = None
    """Returns the simulator's actors factory; imported only when a simulation needs it (the
    laundry fleet server's imports take seconds)."""


class ProfileRegistry:
    """Profiles by name; ``version`` changes with every registration (the config schema
    follows it)."""

    def __init__(self) -> None:
        self._entries: dict[str, Registered] = {}
        self.version = 0

    def register(self, spec: ProfileSpec,
                 actors: Callable[[], ActorsFactory] | None = None) -> None:
        if spec.name in self._entries:
            msg = f"profile {spec.name!r} is registered already"
            raise ValueError(msg)
        self._entries[spec.name] = Registered(spec, actors)
        self.version += 1

    def unregister(self, name: str) -> None:
        del self._entries[name]
        self.version += 1

    @contextlib.contextmanager
    def registered(self, spec: ProfileSpec) -> Iterator[ProfileSpec]:
        """``with PROFILES.registered(spec):`` the profile exists inside the block only."""
        self.register(spec)
        try:
            yield spec
        finally:
            self.unregister(spec.name)

    def names(self) -> list[str]:
        return sorted(self._entries)

    def specs(self) -> list[ProfileSpec]:
        return [self._entries[name].spec for name in self.names()]

    def get(self, name: str) -> Registered:
        """The entry for ``name``; ValueError naming the known profiles otherwise."""
        entry = self._entries.get(name)
        if entry is None:
            msg = f"robot.profile: unknown profile {name!r} (known: {', '.join(self.names())})"
            raise ValueError(msg)
        return entry

    def build(self, name: str) -> Profile:
        """A new profile object for ``robot.profile = name``."""
        profile: Profile = self.get(name).spec.profile()
        return profile

    def sections(self) -> list[Section]:
        """Every registered profile's own config sections, in name order."""
        return [s for spec in self.specs() for s in spec.sections]

    def orders(self) -> list[Order]:
        return [o for spec in self.specs() for o in spec.orders]


def _laundry_actors() -> ActorsFactory:
    from robotd.sim.actors.laundry import LaundryActors

    return LaundryActors.for_scenario


PROFILES = ProfileRegistry()
"""The robot profiles this installation knows."""
PROFILES.register(idle.SPEC)
PROFILES.register(square.SPEC)
PROFILES.register(laundry.SPEC, actors=_laundry_actors)
