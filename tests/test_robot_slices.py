"""A robot lives in its two packages: nothing else names it, and a new one needs nothing else.

DESIGN.md ("Layout"): a robot is its runtime slice (``behaviours/profiles/<name>/``), its
simulator slice (``sim/robots/<name>/``) and one registry line. The daemon, the config loader,
``robotctl``, the framework, the capabilities, the drivers and the simulator iterate over the
registry. The fleet server is left out on purpose: it is the laundry seed's site server, whose
request lifecycle is laundry's by the seed's own words (its statuses, ``DirtyLaundryAtBase``).
"""

from __future__ import annotations

import ast
import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("robotd", "hal", "drivers", "behaviours", "sim")
ROBOTS = ("laundry", "vacuum", "delivery", "cabinet", "patrol", "square", "survey")
"""Every robot profile but ``idle`` (a root state's name as much as a robot's)."""
REGISTRY = "robotd/profiles.py"
SEED_WORDS = {
    # The auto-empty station's suction (the docking seed's own state names vacuum_on and
    # vacuum_off), which every robot with a dock shares; not the vacuum robot.
    ("behaviours/docking/station.py", "vacuum"),
    ("behaviours/docking/tables.py", "vacuum"),
    ("sim/world/vacuum.py", "vacuum"),
    ("sim/world/body.py", "vacuum"),
    # A frame's delivery on the serial link (acknowledged, refused, timed out).
    ("drivers/arduino/__init__.py", "delivery"),
    ("drivers/arduino/link.py", "delivery"),
    ("drivers/arduino/outbox.py", "delivery"),
    ("robotd/probes/serial.py", "delivery"),
}
"""(module, word): a robot's name used as the ordinary word it also is, and why."""


def _words(text: str) -> set[str]:
    return {w.lower() for w in re.split(r"[^A-Za-z0-9]+|_|(?<=[a-z])(?=[A-Z])", text) if w}


def _own(rel: Path) -> bool:
    parts = rel.parts
    return len(parts) > 3 and parts[:2] in (("behaviours", "profiles"), ("sim", "robots"))


def _names(tree: ast.AST) -> list[tuple[int, str]]:
    """Every identifier, imported module and string literal (not docstrings: prose may tell of
    a robot) with its line."""
    prose = {id(n.value) for n in ast.walk(tree)
             if isinstance(n, ast.Expr) and isinstance(n.value, ast.Constant)}
    out: list[tuple[int, str]] = []
    for node in ast.walk(tree):
        line = getattr(node, "lineno", 0)
        if isinstance(node, ast.Name):
            out.append((line, node.id))
        elif isinstance(node, ast.Attribute):
            out.append((line, node.attr))
        elif isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            out.append((line, node.name))
        elif isinstance(node, ast.arg):
            out.append((line, node.arg))
        elif isinstance(node, ast.alias):
            out += [(line, node.name), (line, node.asname or "")]
        elif isinstance(node, ast.ImportFrom):
            out.append((line, node.module or ""))
        elif isinstance(node, ast.keyword):
            out.append((line, node.arg or ""))
        elif isinstance(node, ast.Constant) and isinstance(node.value, str) \
                and id(node) not in prose:
            out.append((line, node.value))
    return out


def robot_names_outside_slices(root: Path) -> list[str]:
    """``module:line: robot`` for each robot named outside its slices and the registry."""
    found = []
    for package in PACKAGES:
        for path in sorted((root / package).rglob("*.py")):
            rel = path.relative_to(root)
            if _own(rel) or rel.as_posix() == REGISTRY:
                continue
            tree = ast.parse(path.read_text(encoding="utf-8"))
            for line, name in _names(tree):
                for robot in sorted(_words(name) & set(ROBOTS)):
                    if (rel.as_posix(), robot) not in SEED_WORDS:
                        found.append(f"{rel}:{line}: {robot} ({name[:60]!r})")
    return found


class TestNoRobotOutsideItsSlices:
    def test_no_module_outside_a_robots_slices_names_it(self) -> None:
        """Only a robot's own two packages and the registry name it: a branch on a robot's
        name anywhere else means the registry is missing a hook."""
        assert robot_names_outside_slices(ROOT) == []

    def test_the_check_finds_a_robot_named_in_the_centre(self, tmp_path: Path) -> None:
        """The check is not blind: a profile name in a string, an identifier or an import
        outside the slices is each found (and a docstring's prose is not)."""
        for package in PACKAGES:
            (tmp_path / package).mkdir()
        (tmp_path / "sim" / "checks.py").write_text(textwrap.dedent('''
            """Checks, including the cabinet robot's (prose: allowed)."""
            from behaviours.profiles.cabinet.config import CABINET
            def draw_delivery(ax): ...
            if profile == "patrol":
                goals = config["laundry"]
        '''))
        found = robot_names_outside_slices(tmp_path)
        named = sorted({f.split(" ")[1] for f in found})
        assert named == ["cabinet", "delivery", "laundry", "patrol"]

    def test_seed_words_name_real_modules(self) -> None:
        """Every exception is a module that exists and still uses the word."""
        for module, word in SEED_WORDS:
            path = ROOT / module
            assert path.exists(), module
            assert word in path.read_text(encoding="utf-8").lower(), (module, word)


SIXTH_RUNTIME = '''
"""A sixth robot, written by a test: it turns on the spot, then it is done."""

from __future__ import annotations

import asyncio
from typing import Any

from behaviours.context import RobotContext
from behaviours.profile import BaseProfile, ProfileSpec, StateTask
from hal.options import Option, Section
from hal.readings import MotorCommand

SPIN = Section("spin", "The spinner.", (
    Option("turn_s", "float", 2.0, "How long it turns.", min=0.1, max=60.0),
))


class SpinnerProfile(BaseProfile):
    name = "spinner"
    devices = ("motors", "encoders")

    def mission_states(self) -> list[str | dict[str, Any]]:
        return ["turning", "done"]

    def mission_transitions(self) -> list[dict[str, Any]]:
        return [{"trigger": "turned", "source": "mission.turning", "dest": "mission.done"}]

    def services(self, ctx: RobotContext) -> list[Any]:
        async def start() -> None:
            await ctx.trigger("start_mission")
            await asyncio.Event().wait()

        from behaviours.service import TaskService

        return [TaskService("spinner.start", start)]

    def state_tasks(self) -> dict[str, StateTask]:
        return {"mission.turning": self._turn}

    async def _turn(self, ctx: RobotContext) -> None:
        motors = ctx.devices.motors
        assert motors is not None
        await motors.drive(MotorCommand(80, 80, left_forward=False))
        await asyncio.sleep(float(ctx.settings.get("spin.turn_s")))
        await motors.stop()
        ctx.emit("spinner.turned")
        await ctx.trigger("turned")


SPEC = ProfileSpec(SpinnerProfile, "turns on the spot", sections=(SPIN,), sim="spinner_sim")
'''

SIXTH_SIM = '''
"""The sixth robot's simulator slice."""

from sim.slice import SimSlice


class SpinCheck:
    keys = ("min_turns",)

    def failures(self, run):
        want = run.extra.get("min_turns")
        got = sum(e.get("kind") == "spinner.turned" for e in run.events)
        return [] if want is None or got >= want else [f"turned {got} times, want {want}"]

    def figures(self, events):
        return {"turns": sum(e.get("kind") == "spinner.turned" for e in events)}


SIM = SimSlice(checks=(SpinCheck(),))
'''

SIXTH_SCENARIO = '''
[scenario]
name = "spinner"
profile = "spinner"

[world]
width_m = 3.0
height_m = 3.0

[robot]
x_m = 1.5
y_m = 1.5

[config.spin]
turn_s = 3.0

[success]
time_limit_s = 30
final_state = "mission.done"
min_turns = 1
'''


@pytest.fixture
def sixth_robot(tmp_path: Path) -> dict[str, str]:
    """A robot in a temporary folder: its runtime slice, its simulator slice with a built-in
    scenario, and one registry line (an entry point, as a robot kept outside this repository
    registers); the environment that puts the folder on the path."""
    runtime = tmp_path / "spinner_robot"
    runtime.mkdir()
    (runtime / "__init__.py").write_text(SIXTH_RUNTIME)
    sim = tmp_path / "spinner_sim"
    (sim / "scenarios").mkdir(parents=True)
    (sim / "__init__.py").write_text(SIXTH_SIM)
    (sim / "scenarios" / "spinner.toml").write_text(SIXTH_SCENARIO)
    dist = tmp_path / "spinner_robot-0.1.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: spinner-robot\nVersion: 0.1\n")
    (dist / "entry_points.txt").write_text("[robotd.profiles]\nspinner = spinner_robot:SPEC\n")
    env = dict(os.environ, PYTHONPATH=str(tmp_path))
    return env


def _robotd(env: dict[str, str], *args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "robotd.cli", *args], env=env, cwd=cwd,
                          capture_output=True, text=True, timeout=240, check=False)


class TestASixthRobot:
    def test_runs_in_the_simulator_by_its_scenario_name(self, sixth_robot: dict[str, str],
                                                        tmp_path: Path) -> None:
        """``robotd sim spinner`` finds the new robot's built-in scenario, runs its mission
        on the simulated motor board and judges it by the slice's own check."""
        run = _robotd(sixth_robot, "sim", "spinner", "--quiet", "--report",
                      str(tmp_path / "out"), cwd=tmp_path)
        assert run.returncode == 0, run.stdout + run.stderr
        assert "scenario spinner: SUCCESS" in run.stdout
        assert "turns 1" in run.stdout
        events = (tmp_path / "out" / "events.jsonl").read_text()
        assert '"kind":"spinner.turned"' in events

    def test_its_own_check_can_fail_the_run(self, sixth_robot: dict[str, str],
                                             tmp_path: Path) -> None:
        """The slice's check is the one that judges: asking for two turns fails the run."""
        scenario = tmp_path / "two.toml"
        scenario.write_text(SIXTH_SCENARIO.replace("min_turns = 1", "min_turns = 2"))
        run = _robotd(sixth_robot, "sim", str(scenario), "--quiet", cwd=tmp_path)
        assert run.returncode == 1, run.stdout + run.stderr
        assert "turned 1 times, want 2" in run.stdout

    def test_check_config_knows_its_section(self, sixth_robot: dict[str, str],
                                            tmp_path: Path) -> None:
        """``robot.profile = "spinner"`` is valid, and its own section is checked."""
        config = tmp_path / "robotd.toml"
        config.write_text('[robot]\nname = "s-1"\nprofile = "spinner"\n\n[spin]\nturn_s = 2.5\n')
        good = _robotd(sixth_robot, "check-config", str(config), cwd=tmp_path)
        assert good.returncode == 0, good.stdout + good.stderr
        config.write_text('[robot]\nname = "s-1"\nprofile = "spinner"\n\n[spin]\nturn_s = 99\n')
        bad = _robotd(sixth_robot, "check-config", str(config), cwd=tmp_path)
        assert bad.returncode == 2
        assert "robotd.toml:6: spin.turn_s:" in bad.stdout + bad.stderr

    def test_without_the_registry_line_it_is_unknown(self, sixth_robot: dict[str, str],
                                                     tmp_path: Path) -> None:
        """The registry line is what adds it: without the entry point, no such profile."""
        for dist in tmp_path.glob("*.dist-info"):
            (dist / "entry_points.txt").unlink()
        config = tmp_path / "robotd.toml"
        config.write_text('[robot]\nname = "s-1"\nprofile = "spinner"\n')
        run = _robotd(sixth_robot, "check-config", str(config), cwd=tmp_path)
        assert run.returncode == 2
        assert "unknown profile 'spinner'" in run.stdout + run.stderr
