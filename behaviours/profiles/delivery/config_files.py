"""The delivery robot's orders database, checked with the config that names it: a config whose
``[delivery]`` section names ``database_url``, or whose robot is the delivery robot (the
default URL then), must name an SQLite file with the seed's ``customers`` and ``orders``
tables (``check-config`` prints ``robotd.toml:LINE: delivery.database_url: /tmp/x.db: no
such file``). The file is opened read-only (a ``mode=ro`` URI): checking never creates or
changes it."""

from __future__ import annotations

import sqlite3
from pathlib import Path
from typing import Any
from urllib.parse import quote

from behaviours.profiles.delivery.orders import sqlite_path
from hal.options import ConfigProblem

TABLES = ("customers", "orders")
"""The seed's schema (``orders.SCHEMA``): the tables order verification reads."""


def delivery_file_problems(values: dict[str, dict[str, Any]], path: str,
                           where: dict[tuple[str, str], int]) -> list[ConfigProblem]:
    """The problem of the database the delivery robot will read; none for other robots'
    configs that do not name one."""
    named = ("delivery", "database_url") in where
    if not named and values.get("robot", {}).get("profile") != "delivery":
        return []
    url = values.get("delivery", {}).get("database_url")
    state_dir = values.get("robot", {}).get("state_dir")
    if not isinstance(url, str) or not isinstance(state_dir, str):
        return []
    line = where.get(("delivery", "database_url"), where.get(("delivery", ""),
                                                             where.get(("robot", "profile"))))
    try:
        file = sqlite_path(url, Path(state_dir))
    except ValueError:
        return []  # the option's pattern has already said so
    why = database_problem(file)
    if why is None:
        return []
    shown = f"{file}: {why}" if named else f"{file} (the default {url}): {why}"
    return [ConfigProblem(path, line, "delivery.database_url", shown)]


def database_problem(file: Path) -> str | None:
    """Why ``file`` is not an orders database the robot can read (None: it is one)."""
    if not file.exists():
        return "no such file" if file.parent.is_dir() else \
            f"no such file (no directory {file.parent})"
    if not file.is_file():
        return "not a regular file"
    uri = f"file:{quote(str(file.resolve()))}?mode=ro"
    try:
        db = sqlite3.connect(uri, uri=True, timeout=1.0)
    except sqlite3.Error as exc:
        return f"cannot open: {exc}"
    try:
        rows = db.execute("SELECT name FROM sqlite_master WHERE type = 'table'").fetchall()
    except sqlite3.DatabaseError as exc:
        text = str(exc)
        return "not an SQLite database" if "not a database" in text else f"cannot read: {text}"
    finally:
        db.close()
    missing = [t for t in TABLES if t not in {str(r[0]) for r in rows}]
    if missing:
        return f"no {'/'.join(missing)} table (the seed's schema: {', '.join(TABLES)})"
    return None
