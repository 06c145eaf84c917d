"""The delivery section: the seed's values as defaults, validated by check-config."""

from __future__ import annotations

import pytest

from behaviours.profiles.delivery.config import timers_from
from behaviours.profiles.delivery.states import Timers, mission_states
from robotd.config import ConfigError, load_config_text
from robotd.config.settings import Settings


def test_defaults_are_the_seeds() -> None:
    """Home (0,0), warehouse (5,3), zone 3 m, 10 cm, 50 cm, 30/60/10/15 s, orders.db."""
    values = load_config_text("", "empty.toml")
    d = values["delivery"]
    assert (d["home_x_m"], d["home_y_m"], d["warehouse_x_m"], d["warehouse_y_m"]) == (
        0.0, 0.0, 5.0, 3.0)
    assert (d["zone_radius_m"], d["position_tolerance_m"], d["approach_distance_m"]) == (
        3.0, 0.1, 0.5)
    assert d["database_url"] == "sqlite:///assets/orders.db"
    assert timers_from(Settings(values)) == Timers(30.0, 60.0, 10.0, 15.0)


def test_the_timers_reach_the_state_table() -> None:
    """A configured (shorter) verifying timeout reaches the timers; longer than the seed's,
    which stays the state table's cap, is refused."""
    values = load_config_text("[delivery]\nverifying_timeout_s = 20\n", "d.toml")
    timers = timers_from(Settings(values))
    assert timers.verifying_timeout_s == 20.0
    table = mission_states(timers)
    verifying = next(s for s in table if isinstance(s, dict) and s["name"] == "verifying")
    assert verifying["timeout"] == 20.0
    with pytest.raises(ConfigError, match="must be <= 30"):
        load_config_text("[delivery]\nverifying_timeout_s = 45\n", "d.toml")


@pytest.mark.parametrize(("text", "problem"), [
    ('database_url = "postgresql://h/orders"', "delivery.database_url: expected sqlite:///PATH"),
    ('zone_radius_m = "3"', "delivery.zone_radius_m: expected a number"),
    ("delivery_duration_s = 15", "delivery.delivering_timeout_s: must be above"),
    ("approach_distance_m = 0.05", "delivery.approach_distance_m"),
    ("colour = 1", "delivery.colour"),
])
def test_bad_values_are_named(text: str, problem: str) -> None:
    """Each bad value is a line naming section.key."""
    with pytest.raises(ConfigError) as info:
        load_config_text(f"[delivery]\n{text}\n", "d.toml")
    assert problem in str(info.value)
