"""The cabinet robot's task list: the seed's "high level tasks" and the task planner's
behaviour, read from a JSON file (format in ``docs/cabinet.md``), problems named like the map's:
``tasks.json: tasks[1].cabinet: unknown cabinet 'c9' (known: c1, c2)``."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from behaviours.profiles.cabinet.map_reader import (
    Problems,
    SiteFileError,
    items,
    number,
    show,
    unknown_keys,
)
from behaviours.profiles.cabinet.site_map import SiteMap

ACTIONS = ("none", "announce", "open_latch", "snapshot")
"""What the robot does in front of a cabinet (``mission.cabinet_action``)."""
ORDERS = ("listed", "nearest")
"""``listed``: tasks in file order; ``nearest``: the nearest (by path) remaining one next."""
ON_UNREACHABLE = ("fail", "skip")
"""A cabinet no path reaches: ``fail`` ends the mission (``mission.failed``); ``skip``
reports it and takes the next task."""

__all__ = ["ACTIONS", "SiteFileError", "Task", "TaskList", "parse_task_list"]


@dataclass(frozen=True, slots=True)
class Task:
    cabinet: str
    action: str = "none"
    standoff_m: float | None = None
    """Overrides ``cabinet.standoff_m`` for this cabinet; None: the config's."""


@dataclass(frozen=True, slots=True)
class TaskList:
    tasks: tuple[Task, ...]
    order: str = "listed"
    on_unreachable: str = "fail"


def parse_task_list(doc: Any, shown: str, site: SiteMap) -> TaskList:
    """A TaskList from a parsed JSON document, checked against the site's cabinets."""
    problems = Problems(shown)
    if not isinstance(doc, dict):
        problems.add("file", f"expected a JSON object, got {show(doc)}")
        problems.raise_any()
    unknown_keys(doc, "", ("behaviour", "tasks"), problems)
    order, on_unreachable = "listed", "fail"
    behaviour = doc.get("behaviour", {})
    if not isinstance(behaviour, dict):
        problems.add("behaviour", f"expected an object, got {show(behaviour)}")
    else:
        unknown_keys(behaviour, "behaviour", ("order", "on_unreachable"), problems)
        order = _choice(behaviour, "order", ORDERS, "behaviour", problems) or order
        on_unreachable = (_choice(behaviour, "on_unreachable", ON_UNREACHABLE, "behaviour",
                                  problems) or on_unreachable)
    known = [c.name for c in site.cabinets]
    tasks = []
    for where, item in items(doc, "tasks", problems, required=True):
        unknown_keys(item, where, ("cabinet", "action", "standoff_m"), problems)
        cabinet = item.get("cabinet")
        if not isinstance(cabinet, str):
            problems.add(f"{where}.cabinet", f"expected a cabinet's name, got {show(cabinet)}")
            continue
        if cabinet not in known:
            problems.add(f"{where}.cabinet",
                         f"unknown cabinet {cabinet!r} (known: {', '.join(known) or 'none'})")
            continue
        action = _choice(item, "action", ACTIONS, where, problems) or "none"
        standoff_m = None
        if "standoff_m" in item:
            standoff_m = number(item["standoff_m"], f"{where}.standoff_m", problems)
            if standoff_m is not None and not 0.05 <= standoff_m <= 3.0:
                problems.add(f"{where}.standoff_m", f"must be within 0.05..3, got {standoff_m}")
                standoff_m = None
        tasks.append(Task(cabinet, action, standoff_m))
    problems.raise_any()
    return TaskList(tuple(tasks), order, on_unreachable)


def _choice(item: dict[str, Any], key: str, choices: tuple[str, ...], where: str,
            problems: Problems) -> str | None:
    if key not in item:
        return None
    value = item[key]
    if isinstance(value, str) and value in choices:
        return value
    problems.add(f"{where}.{key}", f"expected one of {', '.join(choices)}, got {show(value)}")
    return None
