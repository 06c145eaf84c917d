"""The one registry of robot profiles: what ``robot.profile`` may name, and what each brings.

Each profile declares itself beside its code (``behaviours/profiles/<name>/__init__.py``:
``SPEC``: its class, devices, config sections, file checks, robotctl commands, and the name of
its simulator slice); one line here adds it. A robot kept in a package of its own adds itself
with one line of its packaging instead, an entry point in the group ``robotd.profiles``
(``spinner = spinner_robot:SPEC``). ``check-config``, ``example-config``, ``robotctl``,
``robotd sim`` and the daemon all read this registry (docs/profiles.md).
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from importlib.metadata import entry_points

from behaviours.profile import Profile, ProfileSpec
from behaviours.profiles import (
    cabinet,
    delivery,
    idle,
    laundry,
    patrol,
    square,
    survey,
    vacuum,
)
from hal.options import Order, Section


class ProfileRegistry:
    """Profiles by name; ``version`` changes with every registration (the config schema
    follows it)."""

    def __init__(self) -> None:
        self._entries: dict[str, ProfileSpec] = {}
        self.version = 0

    def register(self, spec: ProfileSpec) -> None:
        if spec.name in self._entries:
            msg = f"profile {spec.name!r} is registered already"
            raise ValueError(msg)
        self._entries[spec.name] = spec
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
        return [self._entries[name] for name in self.names()]

    def get(self, name: str) -> ProfileSpec:
        """The profile registered as ``name``; ValueError naming the known ones otherwise."""
        entry = self._entries.get(name)
        if entry is None:
            msg = f"robot.profile: unknown profile {name!r} (known: {', '.join(self.names())})"
            raise ValueError(msg)
        return entry

    def build(self, name: str) -> Profile:
        """A new profile object for ``robot.profile = name``."""
        profile: Profile = self.get(name).profile()
        return profile

    def sections(self) -> list[Section]:
        """Every registered profile's own config sections, in name order."""
        return [s for spec in self.specs() for s in spec.sections]

    def orders(self) -> list[Order]:
        return [o for spec in self.specs() for o in spec.orders]


DEFAULT_PROFILE = "laundry"
"""``robot.profile`` when a config names none."""
DEFAULT_SCENARIO = "laundry"
"""The scenario ``robotd sim`` runs when given none (a built-in of that robot's slice)."""
DEFAULT_SIM_PROFILE = "square"
"""The profile of a scenario file that names none (``[scenario] profile``)."""

MAPPING_PROFILE = survey.SPEC.name
"""The profile ``robotd map`` runs (without ``--from-log``): the robot's drivers mapping live."""

PROFILES = ProfileRegistry()
"""The robot profiles this installation knows."""
PROFILES.register(idle.SPEC)
PROFILES.register(square.SPEC)
PROFILES.register(laundry.SPEC)
PROFILES.register(patrol.SPEC)
PROFILES.register(vacuum.SPEC)
PROFILES.register(delivery.SPEC)
PROFILES.register(cabinet.SPEC)
PROFILES.register(survey.SPEC)


def _register_installed(registry: ProfileRegistry) -> None:
    """The profiles installed packages declare (entry point group ``robotd.profiles``)."""
    for entry in entry_points(group=ENTRY_POINT_GROUP):
        spec = entry.load()
        if not isinstance(spec, ProfileSpec):
            msg = f"entry point {entry.name} = {entry.value}: not a ProfileSpec"
            raise TypeError(msg)
        registry.register(spec)


ENTRY_POINT_GROUP = "robotd.profiles"
_register_installed(PROFILES)
