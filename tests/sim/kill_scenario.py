"""A one-robot, one-customer laundry scenario with the robot's daemon killed mid-mission."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

SCENARIOS = Path(__file__).resolve().parents[2] / "sim" / "robots" / "laundry" / "scenarios"


def write_kill_scenario(directory: Path, *, when_state: str, delay_s: float,
                        restart_after_s: float = 2.0, load_kg: float = 4.2) -> Path:
    """``laundry.toml`` cut to laundry-1 and customer 1, with ``robot.kill`` once the robot
    has been ``delay_s`` in ``when_state``; the daemon restarts ``restart_after_s`` later."""
    text = (SCENARIOS / "laundry.toml").read_text()
    head = text[:text.index("[[robots]]")]
    head = re.sub(r"customers = \[.*?\n\]\n", "customers = [\n    { customer = 1, "
                  f"request_at_s = 5.0, load_kg = {load_kg} }},\n]\n", head, flags=re.S)
    head = head.replace('name = "laundry"', 'name = "laundry-kill"', 1)
    scenario = directory / "laundry-kill.toml"
    scenario.write_text(head + f"""
[[robots]]
name = "laundry-1"
x_m = 2.6
y_m = 1.0
heading_deg = 0

[[script]]
at_s = 0.0
robot = "laundry-1"
when_state = "{when_state}"
delay_s = {delay_s}
action = "robot.kill"
duration_s = {restart_after_s}

[success]
time_limit_s = 600
final_state = "idle"
no_collisions = true
requests = [ {{ customer = 1, status = "Completed", paid = true }} ]
final_rooms = [ {{ robot = "laundry-1", room = "base" }} ]
""")
    shutil.copy(SCENARIOS / "laundry-site.toml", directory / "laundry-site.toml")
    return scenario
