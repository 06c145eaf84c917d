"""Scenario files: a world, the robots in it, a script of timed events and success conditions.

A scenario is TOML (see docs/scenarios.md). Built-in scenarios ship in each robot's simulator
slice (``sim/robots/<name>/scenarios``); ``load_scenario("square")`` finds one by name,
anything else is read as a path.
"""

from __future__ import annotations

import difflib
import math
import tomllib
from dataclasses import dataclass, field
from importlib.resources.abc import Traversable
from pathlib import Path
from typing import Any

from hal.files import FileRefused, read_bounded_text
from robotd.profiles import DEFAULT_SIM_PROFILE
from sim.registry import distinct, scenario_folders, slices
from sim.world.body import BodyParams
from sim.world.floor_plan import World, WorldError

MAX_SCENARIO_BYTES = 4 * 1024 * 1024
"""A scenario or a site file it names (the laundry world's line is the longest: 20 kB)."""


class ScenarioError(ValueError):
    """A scenario file is wrong; the message names the file and the key."""


@dataclass(frozen=True, slots=True)
class RobotSpec:
    name: str
    x_m: float
    y_m: float
    heading_rad: float
    config: dict[str, dict[str, Any]]
    body: BodyParams
    payload_kg: float = 0.0


@dataclass(frozen=True, slots=True)
class ScriptStep:
    at_s: float
    action: str
    args: dict[str, Any]


@dataclass(frozen=True, slots=True)
class FinalPose:
    x_m: float
    y_m: float
    tolerance_m: float
    robot: str = ""


@dataclass(frozen=True, slots=True)
class Success:
    time_limit_s: float
    states_reached: tuple[str, ...] = ()
    final_state: str | None = None
    final_states: tuple[str, ...] = ()
    """Every state a robot may end in (``final_state`` as a list: e.g. the front robot of the
    queue at base idle, those behind it ``mission.queued``); ``(final_state,)`` otherwise."""
    final_poses: tuple[FinalPose, ...] = ()
    no_estop: bool = True
    no_collisions: bool = True
    max_cross_track_m: float | None = None
    extra: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True, slots=True)
class Scenario:
    name: str
    description: str
    profile: str
    source: str
    world: World
    robots: tuple[RobotSpec, ...]
    script: tuple[ScriptStep, ...]
    success: Success
    config: dict[str, dict[str, Any]]
    raw: dict[str, Any]

    @property
    def profiles(self) -> tuple[str, ...]:
        """The profiles of its robots, each once, in the robots' order."""
        default = str(self.config.get("robot", {}).get("profile", self.profile))
        named = (str(r.config.get("robot", {}).get("profile", default)) for r in self.robots)
        return tuple(dict.fromkeys(named))


def read_beside(scenario: Scenario, name: str) -> str:
    """A file named in a scenario, relative to the scenario (built-ins: beside them)."""
    builtin = _builtin_name(scenario.source)
    if builtin is not None:
        return (builtins()[builtin] / name).read_text(encoding="utf-8")
    path = Path(scenario.source).parent / name
    try:
        return read_bounded_text(path, MAX_SCENARIO_BYTES, "file a scenario names")
    except FileRefused as exc:
        msg = f"{scenario.source}: {name}: cannot read: {exc.why}"
        raise ScenarioError(msg) from None


def scenario_dir(source: str) -> Path:
    """Where files a scenario names are (built-ins: beside them, in their robot's slice)."""
    builtin = _builtin_name(source)
    if builtin is not None:
        return Path(str(builtins()[builtin]))
    return Path(source).parent


def _builtin_name(source: str) -> str | None:
    if source.startswith("<builtin ") and source.endswith(">"):
        return source[len("<builtin "):-1]
    return None


def builtins() -> dict[str, Traversable]:
    """Built-in scenario name -> the folder it is in (a robot slice's ``scenarios``)."""
    found: dict[str, Traversable] = {}
    for folder in scenario_folders():
        for p in folder.iterdir():
            if p.name.endswith(".toml") and not p.name.endswith("-site.toml"):
                name = p.name[:-5]
                if name in found:
                    msg = f"built-in scenario {name!r} is in two robot slices"
                    raise ValueError(msg)
                found[name] = folder
    return dict(sorted(found.items()))


def builtin_names() -> list[str]:
    return list(builtins())


def load_scenario(name_or_path: str) -> Scenario:
    """A built-in scenario by name, or a scenario file by path."""
    folders = builtins()
    if name_or_path in folders:
        res = folders[name_or_path] / f"{name_or_path}.toml"
        return parse_scenario(res.read_text(encoding="utf-8"), f"<builtin {name_or_path}>")
    path = Path(name_or_path)
    if not path.exists():
        msg = (f"{name_or_path}: no such scenario file, and not a built-in scenario "
               f"(built-in: {', '.join(folders)})")
        raise ScenarioError(msg)
    try:
        text = read_bounded_text(path, MAX_SCENARIO_BYTES, "scenario")
    except FileRefused as exc:
        raise ScenarioError(str(exc)) from None
    return parse_scenario(text, str(path))


def parse_scenario(text: str, source: str) -> Scenario:
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        msg = f"{source}: TOML syntax error: {exc}"
        raise ScenarioError(msg) from exc
    try:
        return _build(raw, source)
    except (WorldError, KeyError, TypeError, ValueError) as exc:
        msg = f"{source}: {exc}"
        raise ScenarioError(msg) from exc


_TOP = ("scenario", "config", "world", "robot", "robots", "script", "success")
_SCENARIO = ("name", "description", "profile", "seed")
_ROBOT = ("name", "x_m", "y_m", "heading_deg", "config", "body", "payload_kg")
_COMMON_SUCCESS = ("time_limit_s", "states_reached", "final_state", "final_poses", "no_estop",
                   "no_collisions", "max_cross_track_m", "arrivals", "requests", "final_rooms")


def success_keys() -> tuple[str, ...]:
    """Every ``[success]`` key: the common ones and each robot slice's checks' own."""
    own = (key for sim in slices() for check in sim.checks for key in check.keys)
    return tuple(dict.fromkeys((*_COMMON_SUCCESS, *own)))


_STEP = ("at_s", "action", "robot", "duration_s", "pct", "kg", "name", "x_m", "y_m", "key",
         "value", "when_state", "delay_s", "points", "speed_mps", "loop", "heading_deg", "dx_m",
         "dy_m")


def check_keys(table: dict[str, Any], known: tuple[str, ...], where: str) -> None:
    """ValueError naming the first key of ``table`` that is not in ``known``."""
    for key in table:
        if key not in known:
            close = difflib.get_close_matches(key, known, n=1)
            hint = f"did you mean {close[0]!r}?" if close else f"known: {', '.join(known)}"
            msg = f"{where}{'.' if where else ''}{key}: unknown key ({hint})"
            raise ValueError(msg)


SITE_FLEET_KEYS = ("site", "settings", "watch_s", "orders")
"""The ``[fleet]`` keys the simulator's site fleet reads (``sim.actors.site_fleet``), for the
robots of any profile; a slice that runs its own fleet (laundry) adds its own keys."""


def _scenario_tables() -> dict[str, tuple[str, ...] | None]:
    """The top-level tables the slices' actors read, with their keys (a table several
    declare, such as ``fleet``, takes the keys of all; None: its actors check it)."""
    tables: dict[str, tuple[str, ...] | None] = {"fleet": SITE_FLEET_KEYS}
    for sim in slices():
        for name, keys in sim.scenario_tables.items():
            known = tables.get(name, ())
            tables[name] = None if keys is None or (name in tables and known is None) \
                else tuple(dict.fromkeys((*(known or ()), *keys)))
    return tables


def _build(raw: dict[str, Any], source: str) -> Scenario:
    tables = _scenario_tables()
    check_keys(raw, (*_TOP, *tables), "")
    meta = _table(raw, "scenario")
    check_keys(meta, _SCENARIO, "scenario")
    for table, keys in tables.items():
        if table in raw and keys is not None:
            check_keys(_table(raw, table), keys, table)
    name = str(meta.get("name", Path(source).stem))
    profile = str(meta.get("profile", DEFAULT_SIM_PROFILE))
    base_dir = scenario_dir(source)
    world_table = _table(raw, "world")
    for part in distinct(p for sim in slices() for p in sim.world_parts):
        world_table = part(world_table, base_dir)
    world = World.from_table(world_table, base_dir=base_dir)
    config = _table(raw, "config", required=False)
    robots_raw = raw.get("robots")
    if robots_raw is None:
        robots_raw = [_table(raw, "robot")]
    if not isinstance(robots_raw, list) or not robots_raw:
        msg = "robots: expected at least one [[robots]] table"
        raise ValueError(msg)
    robots = tuple(_robot(t, i, len(robots_raw)) for i, t in enumerate(robots_raw))
    script = tuple(sorted((_step(t, i) for i, t in enumerate(raw.get("script", []))),
                          key=lambda s: s.at_s))
    success = _success(_table(raw, "success"), robots)
    return Scenario(name, str(meta.get("description", "")), profile, source, world, robots,
                    script, success, config, raw)


def _table(raw: dict[str, Any], key: str, *, required: bool = True) -> dict[str, Any]:
    value = raw.get(key)
    if value is None:
        if required:
            msg = f"[{key}]: required table is missing"
            raise ValueError(msg)
        return {}
    if not isinstance(value, dict):
        msg = f"{key}: expected a table"
        raise ValueError(msg)
    return value


def _num(table: dict[str, Any], key: str, where: str, default: float | None = None) -> float:
    value = table.get(key, default)
    if isinstance(value, bool) or not isinstance(value, int | float):
        msg = f"{where}.{key}: expected a number, got {value!r}"
        raise ValueError(msg)
    return float(value)


def _robot(t: Any, index: int, count: int) -> RobotSpec:
    where = "robot" if count == 1 else f"robots[{index}]"
    if not isinstance(t, dict):
        msg = f"{where}: expected a table"
        raise ValueError(msg)
    check_keys(t, _ROBOT, where)
    body_raw = t.get("body", {})
    known = set(BodyParams.__dataclass_fields__)
    unknown = set(body_raw) - known
    if unknown:
        msg = f"{where}.body.{sorted(unknown)[0]}: unknown key (known: {', '.join(sorted(known))})"
        raise ValueError(msg)
    return RobotSpec(
        name=str(t.get("name", f"sim-{index + 1}")),
        x_m=_num(t, "x_m", where), y_m=_num(t, "y_m", where),
        heading_rad=math.radians(_num(t, "heading_deg", where, 0.0)),
        config=t.get("config", {}),
        body=BodyParams(**body_raw),
        payload_kg=_num(t, "payload_kg", where, 0.0),
    )


def _step(t: Any, index: int) -> ScriptStep:
    where = f"script[{index}]"
    if not isinstance(t, dict) or "action" not in t:
        msg = f"{where}: expected a table with at_s and action"
        raise ValueError(msg)
    check_keys(t, _STEP, where)
    args = {k: v for k, v in t.items() if k not in ("at_s", "action")}
    return ScriptStep(_num(t, "at_s", where), str(t["action"]), args)


def _success(t: dict[str, Any], robots: tuple[RobotSpec, ...]) -> Success:
    check_keys(t, success_keys(), "success")
    poses = []
    for i, p in enumerate(t.get("final_poses", [])):
        where = f"success.final_poses[{i}]"
        robot = str(p.get("robot", robots[0].name))
        spec = next((r for r in robots if r.name == robot), None)
        if spec is None:
            msg = f"{where}.robot: no robot named {robot!r}"
            raise ValueError(msg)
        if p.get("at") == "start":
            x, y = spec.x_m, spec.y_m
        else:
            x, y = _num(p, "x_m", where), _num(p, "y_m", where)
        poses.append(FinalPose(x, y, _num(p, "tolerance_m", where, 0.05), robot))
    known = {"time_limit_s", "states_reached", "final_state", "final_poses", "no_estop",
             "no_collisions", "max_cross_track_m"}
    final = t.get("final_state")
    finals = tuple(str(s) for s in final) if isinstance(final, list) else (
        () if final is None else (str(final),))
    return Success(
        time_limit_s=_num(t, "time_limit_s", "success", 600.0),
        states_reached=tuple(t.get("states_reached", ())),
        final_state=finals[0] if finals else None,
        final_states=finals,
        final_poses=tuple(poses),
        no_estop=bool(t.get("no_estop", True)),
        no_collisions=bool(t.get("no_collisions", True)),
        max_cross_track_m=t.get("max_cross_track_m"),
        extra={k: v for k, v in t.items() if k not in known},
    )
