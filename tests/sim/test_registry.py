"""The simulator's side of the registry: every robot's slice resolves, and what it brings."""

from __future__ import annotations

from pathlib import Path

import pytest

from robotd.profiles import PROFILES
from sim.actors import actors_factory
from sim.registry import slice_of, slices
from sim.scenario import builtin_names, builtins, load_scenario, success_keys
from sim.slice import SimSlice


class TestEveryRegisteredProfile:
    @pytest.mark.parametrize("name", PROFILES.names())
    def test_its_slice_and_actors_resolve(self, name: str) -> None:
        """A slice is found by name (``ProfileSpec.sim`` or ``sim.robots.<name>``), and the
        actors it names, a name and not an import, resolve to a factory."""
        sim = slice_of(name)
        assert isinstance(sim, SimSlice)
        factory = actors_factory(name)
        assert (factory is None) == (sim.actors is None)

    def test_a_profile_without_a_slice_has_an_empty_one(self) -> None:
        """``idle`` has no simulator package: no scenarios, checks or actors of its own."""
        assert slice_of("idle") == SimSlice(scenarios=None)


class TestBuiltinScenarios:
    def test_every_robot_slice_brings_its_own(self) -> None:
        """Each built-in scenario is found in the slice of the robot it runs."""
        for name, folder in builtins().items():
            scenario = load_scenario(name)
            assert f"/sim/robots/{scenario.profile}/" in str(folder), (name, folder)

    def test_the_shipped_set_is_all_there(self) -> None:
        """The scenarios the README lists are all still built in."""
        assert {"laundry", "laundry-loop", "square", "docking", "docking-rear", "nav",
                "nav-map", "nav-kidnap", "cabinet", "cabinet-sealed", "delivery",
                "delivery-faults", "depot-square", "nav-depot", "delivery-warehouse",
                "delivery-warehouse-kidnap", "laundry-busy"} <= set(builtin_names())

    def test_the_readme_lists_every_built_in(self) -> None:
        """A new user finds each built-in scenario in the README's table (issue 31)."""
        readme = (Path(__file__).parents[2] / "README.md").read_text()
        assert [n for n in builtin_names() if f"`{n}`" not in readme] == []

    def test_success_keys_are_the_common_and_each_slices_own(self) -> None:
        keys = success_keys()
        for sim in slices():
            for check in sim.checks:
                assert set(check.keys) <= set(keys)
        assert {"time_limit_s", "arrivals", "min_pose_rate_hz", "box_openings",
                "cabinets_in_order"} <= set(keys)
