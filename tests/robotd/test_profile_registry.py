"""The profile registry: one list of robots that check-config, example-config, robotd sim
and the daemon all read."""

from __future__ import annotations

import importlib
from pathlib import Path

import pytest

from behaviours.profile import BaseProfile, ProfileSpec
from hal.options import Option, Section
from robotd import cli
from robotd.config.sections import SECTIONS
from robotd.profiles import PROFILES


class _Throwaway(BaseProfile):
    name = "throwaway"
    devices = ("motors",)


THROWAWAY = ProfileSpec(
    _Throwaway, "a robot that exists only inside this test",
    sections=(Section("throwaway", "Settings of the throwaway robot.", (
        Option("speed_mps", "float", 0.4, "How fast it throws things away.", min=0, max=2),
    )),),
)


class TestUnknownProfiles:
    def test_check_config_refuses_a_profile_that_is_not_registered(
            self, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
        """``robot.profile = "courier"`` while no such profile exists: exit 2 and the line
        names the known profiles (check-config once said ok, then robotd run failed)."""
        path = tmp_path / "robotd.toml"
        path.write_text('[robot]\nname = "r1"\nprofile = "courier"\n')
        assert cli.main(["check-config", str(path)]) == 2
        known = ", ".join(PROFILES.names())
        assert capsys.readouterr().out.splitlines() == [
            f"{path}:3: robot.profile: unknown profile 'courier' (known: {known})"]

    def test_robot_profile_allows_exactly_the_registered_names(self) -> None:
        """The option's choices are the registry's names, no list of its own."""
        choices = SECTIONS["robot"].by_key["profile"].choices
        assert choices is not None
        assert sorted(map(str, choices)) == PROFILES.names()


class TestAThrowawayProfile:
    def test_it_appears_in_check_config_example_config_and_sim_help(
            self, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
        """Adding a profile is its package (a spec) plus one registration; every tool sees it
        and forgets it when it goes."""
        path = tmp_path / "robotd.toml"
        path.write_text('[robot]\nprofile = "throwaway"\n[throwaway]\nspeed_mps = 1.5\n')
        with PROFILES.registered(THROWAWAY):
            assert cli.main(["check-config", str(path)]) == 0
            assert capsys.readouterr().out == f"{path}: ok\n"
            assert cli.main(["example-config"]) == 0
            example = capsys.readouterr().out
            assert "[throwaway]\n# Settings of the throwaway robot." in example
            assert "throwaway" in example.split("[robot]")[1].split("[hal]")[0]
            with pytest.raises(SystemExit):
                cli.main(["sim", "--help"])
            assert "throwaway: a robot that exists only inside this test" in " ".join(
                capsys.readouterr().out.split())
            assert PROFILES.build("throwaway").devices == ("motors",)
        assert "throwaway" not in PROFILES.names()
        assert cli.main(["check-config", str(path)]) == 2
        out = capsys.readouterr().out
        assert "robot.profile: unknown profile 'throwaway'" in out
        assert "throwaway: unknown section" in out

    def test_a_name_is_registered_once(self) -> None:
        with PROFILES.registered(THROWAWAY), pytest.raises(ValueError, match="already"):
            PROFILES.register(THROWAWAY)


class TestEveryRegisteredProfile:
    @pytest.mark.parametrize("name", PROFILES.names())
    def test_builds_under_its_own_name(self, name: str) -> None:
        spec = PROFILES.get(name)
        profile = PROFILES.build(name)
        assert (profile.name, tuple(profile.devices)) == (spec.name, spec.devices)

    @pytest.mark.parametrize("name", PROFILES.names())
    def test_its_package_holds_its_spec(self, name: str) -> None:
        """Each profile is one package under behaviours/profiles/ with its SPEC."""
        package = importlib.import_module(f"behaviours.profiles.{name}")
        assert package.SPEC is PROFILES.get(name)
