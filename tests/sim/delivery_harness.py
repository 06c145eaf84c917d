"""Whole delivery missions for tests: the real daemon, profile and drivers on the simulator's
devices (the LD19's bytes, the motor board's serial frames, the camera's pixels), in virtual
time, without the report (events only)."""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path
from typing import Any

from sim import vclock
from sim.console import SimConsole
from sim.runner import SimResult, _run
from sim.scenario import parse_scenario

SCENARIOS = Path(__file__).resolve().parents[2] / "sim" / "robots" / "delivery" / "scenarios"
_TEMPLATE = (SCENARIOS / "delivery.toml").read_text()
HEAD = _TEMPLATE[_TEMPLATE.index("[config.robot]"):_TEMPLATE.index("[world]")]
"""The delivery scenario's config and orders (customer 3, order 7, key k3-b81d02)."""
ORDER_7 = '{"order_id": 7, "secret_key": "k3-b81d02"}'
WORLD = """[world]
x_min_m = -2.0
y_min_m = -2.0
width_m = 9.0
height_m = 7.0
boxes = [
    { x_min_m = 3.4, y_min_m = 0.6, x_max_m = 3.8, y_max_m = 5.0 },
    { x_min_m = -2.0, y_min_m = 3.9, x_max_m = -0.6, y_max_m = 5.0 },
]
"""


def person(name: str, x_m: float, y_m: float, qr: str | None = None) -> str:
    code = f", qr_payload = '{qr}'" if qr is not None else ""
    return f'    {{ name = "{name}", x_m = {x_m:.4f}, y_m = {y_m:.4f}{code} }},\n'


def mission_text(*, start: tuple[float, float, float] = (0.0, 0.0, 0.0),
                 people: str = "", script: str = "", success: str, config: str = "") -> str:
    """A delivery scenario: the robot at ``start`` (and localised there), ``people``
    (``person(...)`` lines), ``script`` and ``success`` TOML, extra ``config`` TOML."""
    x, y, h = start
    head = HEAD.replace("initial_x_m = 0.0", f"initial_x_m = {x:.4f}").replace(
        "initial_y_m = 0.0", f"initial_y_m = {y:.4f}").replace(
        "initial_heading_deg = 0.0", f"initial_heading_deg = {h:.2f}")
    return (f'[scenario]\nname = "delivery-test"\nprofile = "delivery"\n\n{head}{config}\n'
            f"{WORLD}people = [\n{people}]\n\n[robot]\nname = \"sim-1\"\nx_m = {x:.4f}\n"
            f"y_m = {y:.4f}\nheading_deg = {h:.2f}\n\n{script}\n[success]\n{success}\n")


def run_mission(text: str, seed: int = 1) -> SimResult:
    """Run the scenario ``text``; the result holds every event and the unmet conditions."""
    scenario = parse_scenario(text, "delivery-test.toml")
    args = argparse.Namespace(seed=seed, quiet=True, mcu="fake", config=None, socket=None)
    with tempfile.TemporaryDirectory(prefix="delivery-test-") as workdir:
        result = vclock.run(_run(args, scenario, SimConsole(quiet=True), Path(workdir)))
    assert not isinstance(result, int), f"the scenario did not start ({result})"
    return result


def kinds(events: list[dict[str, Any]], kind: str) -> list[dict[str, Any]]:
    return [e for e in events if e.get("kind") == kind]


def moves(events: list[dict[str, Any]]) -> list[tuple[str, str, str]]:
    return [(str(e["src"]), str(e["trigger"]), str(e["dst"]))
            for e in events if e.get("kind") == "transition"]
