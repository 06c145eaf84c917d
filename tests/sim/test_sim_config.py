"""A simulated robot's settings: the scenario's config, then only what a --config file sets."""

from __future__ import annotations

from datetime import UTC, datetime
from pathlib import Path

import pytest

from robotd.config import ConfigError
from robotd.config.settings import Settings
from sim.actors import ActorContext
from sim.config import robot_settings
from sim.robots.laundry.actors import LaundryActors
from sim.scenario import load_scenario


def _settings_with(tmp_path: Path, text: str, scenario: str = "laundry-loop") -> Settings:
    config = tmp_path / "robot.toml"
    config.write_text(text)
    loaded = load_scenario(scenario)
    return robot_settings(loaded, loaded.robots[0], str(config))


class TestConfigFileLaidOver:
    def test_the_file_changes_only_the_keys_it_sets(self, tmp_path: Path) -> None:
        """The file's own keys win, the scenario's others stay (the file's defaults once
        emptied laundry-loop's route: the robot never left idle)."""
        settings = _settings_with(tmp_path, "[ble]\nsmoothing_s = 2.0\n")
        assert settings.get("ble.smoothing_s") == 2.0
        assert settings.get("laundry.route") == ["103", "base"]
        assert settings.get("ble.uuids") == ["E2C56DB5-DFFB-48D2-B060-D0F5A71096E0"]

    def test_limits_out_of_order_name_the_file_and_the_line(self, tmp_path: Path) -> None:
        """Limits are checked on the merged config; a pair the file breaks is reported at
        its line in the file."""
        with pytest.raises(ConfigError, match=r"robot.toml: weight.max_kg: must be above"):
            _settings_with(tmp_path, "[weight]\nmin_kg = 50.0\n")
        with pytest.raises(ConfigError, match=r"robot.toml:3: weight.max_kg"):
            _settings_with(tmp_path, "[weight]\nmin_kg = 5.0\nmax_kg = 2.0\n")

    async def test_a_simulated_robot_never_talks_to_the_fleet_server_the_file_names(
            self, tmp_path: Path) -> None:
        """A robot's real config laid over a scenario: the simulated robot stays on the
        simulated hardware and off the real fleet server; a scenario with a fleet points it
        at the simulation's (its actors do, before the robot is built)."""
        text = '[fleet]\nurl = "http://fleet.example:8080"\n[hal]\nbackend = "real"\n'
        alone = _settings_with(tmp_path, text)
        assert alone.get("fleet.url") == ""
        assert alone.get("hal.backend") == "sim"
        with_fleet = _settings_with(tmp_path, text, scenario="laundry")
        assert with_fleet.get("fleet.url") == ""
        scenario = load_scenario("laundry")
        actors = LaundryActors.for_scenario(ActorContext(
            scenario, tmp_path, datetime(2026, 1, 1, tzinfo=UTC), lambda _e: None,
            lambda _r, _kg: None))
        assert actors is not None
        actors.configure_robot(with_fleet)
        await actors.close()
        assert with_fleet.get("fleet.url").startswith("http://")
        assert "fleet.example" not in with_fleet.get("fleet.url")
