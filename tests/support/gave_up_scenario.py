"""A vacuum that gives up docking on a site with a fleet server: ``docking-rear`` with the
dock's contacts faulty for good (seed 2: the seed's retries and fallbacks spent at about
351 s, then the robot in recovery with the fault dock_failed until recovery's timeout e-stops
it), for the simulator's fleet test and the console's browser test."""

from __future__ import annotations

from pathlib import Path

VACUUM_SCENARIOS = Path(__file__).parents[2] / "sim" / "robots" / "vacuum" / "scenarios"


def gave_up_scenario(directory: Path) -> Path:
    """Writes ``gave-up.toml`` in ``directory``; returns its path (run it with seed 2)."""
    text = (VACUUM_SCENARIOS / "docking-rear.toml").read_text()
    head, _, _ = text.partition("[success]")
    path = directory / "gave-up.toml"
    path.write_text(head.replace('name = "docking-rear"', 'name = "gave-up"') + """
[[script]]
at_s = 0.5
action = "dock.contacts_fault"

[fleet]
watch_s = 1.0

[success]
time_limit_s = 1500
final_state = "estop"
no_estop = false
no_collisions = false
""")
    return path
