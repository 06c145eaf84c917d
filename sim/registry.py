"""The simulator's side of the robot registry: each registered profile's ``SimSlice``.

The runtime registry (``robotd.profiles.PROFILES``) is the one list of robots; a profile's
simulator slice is the package ``ProfileSpec.sim`` names (by default ``sim.robots.<name>``),
found here by name, so adding a robot touches no module of the simulator.
"""

from __future__ import annotations

import importlib
import importlib.util
from collections.abc import Iterable, Iterator
from importlib import resources
from importlib.resources.abc import Traversable
from typing import TypeVar

from behaviours.profile import ProfileSpec
from robotd.profiles import PROFILES
from sim.slice import SimSlice

T = TypeVar("T")

_cache: dict[tuple[str, int], tuple[str, SimSlice] | None] = {}


def slice_module(spec: ProfileSpec) -> str:
    """The module that holds ``spec``'s simulator slice (``SIM``)."""
    return spec.sim or f"sim.robots.{spec.name}"


def _load(spec: ProfileSpec) -> tuple[str, SimSlice] | None:
    key = (spec.name, PROFILES.version)
    if key not in _cache:
        module_name = slice_module(spec)
        try:
            found = importlib.util.find_spec(module_name)
        except ModuleNotFoundError:
            found = None
        if found is None:
            if spec.sim is not None:
                msg = f"profile {spec.name!r}: its simulator slice {module_name!r} is missing"
                raise ModuleNotFoundError(msg)
            _cache[key] = None
        else:
            sim = getattr(importlib.import_module(module_name), "SIM", None)
            if not isinstance(sim, SimSlice):
                msg = f"profile {spec.name!r}: {module_name}.SIM is not a SimSlice"
                raise TypeError(msg)
            _cache[key] = (module_name, sim)
    return _cache[key]


def slice_of(profile: str) -> SimSlice:
    """The simulator slice of the profile named ``profile`` (an empty one if it has none)."""
    loaded = _load(PROFILES.get(profile))
    return loaded[1] if loaded is not None else SimSlice(scenarios=None)


def slices() -> Iterator[SimSlice]:
    """Every registered profile's simulator slice, in the registry's order."""
    for spec in PROFILES.specs():
        loaded = _load(spec)
        if loaded is not None:
            yield loaded[1]


def scenario_folders() -> Iterator[Traversable]:
    """Every slice's folder of built-in scenarios."""
    for spec in PROFILES.specs():
        loaded = _load(spec)
        if loaded is None:
            continue
        module_name, sim = loaded
        if sim.scenarios is None:
            continue
        folder = resources.files(module_name) / sim.scenarios
        if folder.is_dir():
            yield folder


def distinct(items: Iterable[T]) -> list[T]:
    """``items`` without repeats (by identity), in order: a check two slices share runs once."""
    out: list[T] = []
    for item in items:
        if not any(item is seen for seen in out):
            out.append(item)
    return out
