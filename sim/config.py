"""A simulated robot's settings: defaults, the scenario's config, then a ``--config`` file's.

Each layer's keys replace the value before them (a table-valued key such as
``laundry.beacons`` whole); the limits that must be in order are checked once every layer is
in. A simulated robot runs on the simulated hardware and talks to the simulation's fleet
server or to none - whatever the file says about ``hal.backend`` or ``fleet.url``.
"""

from __future__ import annotations

from typing import Any

from robotd.config import ConfigError
from robotd.config.errors import ConfigProblem
from robotd.config.loader import defaults, lay_over, order_problems
from robotd.config.settings import Settings
from sim.scenario import RobotSpec, Scenario


def robot_settings(scenario: Scenario, spec: RobotSpec, config_path: str | None) -> Settings:
    """Defaults, the scenario's [config] and [robot.config], then the keys a --config file
    sets (each replaces the value before it; a table-valued key such as laundry.beacons whole)."""
    values = defaults()
    values["robot"]["profile"] = scenario.profile
    problems: list[ConfigProblem] = []
    _apply(values, scenario.config, f"{scenario.source} [config]", problems)
    _apply(values, spec.config, f"{scenario.source} [robot.config]", problems)
    if not problems and not config_path:  # limits in order, once every table is in
        problems = order_problems(values, f"{scenario.source} [config]", {})
    if problems:
        raise ConfigError(problems)
    if config_path:  # its own keys only: its defaults must not undo the scenario's config
        lay_over(values, config_path)
    values["hal"]["backend"] = "sim"
    values["robot"]["name"] = spec.name
    # Never the server a robot's own config file names: the simulation's actors point it at
    # theirs (SimActors.configure_robot), or at none.
    values["fleet"]["url"] = ""
    return Settings(values, source=scenario.source)


def _apply(values: dict[str, dict[str, Any]], table: dict[str, Any], where: str,
           problems: list[ConfigProblem]) -> None:
    for section, keys in table.items():
        if not isinstance(keys, dict):
            problems.append(ConfigProblem(where, None, section, "expected a table"))
            continue
        for key, value in keys.items():
            dotted = f"{section}.{key}"
            try:
                checked, error = Settings.option(dotted).check(value)
            except KeyError as exc:
                error = str(exc.args[0]).removeprefix(f"{dotted}: ")
            if error is not None:
                problems.append(ConfigProblem(where, None, dotted, error))
            else:
                values[section][key] = checked
