"""Load a TOML config file, check it against the schema, and say every problem with its line."""

from __future__ import annotations

import difflib
import re
import tomllib
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from hal.options import Order, Section
from robotd.config.errors import ConfigError, ConfigProblem
from robotd.config.sections import ORDERS, SECTIONS

Values = dict[str, dict[str, Any]]

_SYNTAX_LINE = re.compile(r"\(at line (\d+), column (\d+)\)")
_HEADER = re.compile(r"^\s*\[\[?\s*([A-Za-z0-9_.\-\"' ]+?)\s*\]\]?\s*(#.*)?$")
_KEY = re.compile(r"^\s*([A-Za-z0-9_\-.\"']+)\s*=")
_MAX_SYNTAX_ERRORS = 50


def defaults(sections: Mapping[str, Section] = SECTIONS) -> Values:
    """Every section with every key at its default."""
    return {name: {o.key: o.default for o in s.options} for name, s in sections.items()}


def load_config(path: str | Path, *, overrides: str | Path | None = None) -> Values:
    """Read and check ``path`` (and an overrides file over it); raise ConfigError."""
    path = Path(path)
    values = load_config_text(_read(path), str(path))
    if overrides is not None and Path(overrides).exists():
        lay_over(values, overrides)
    return values


def lay_over(values: Values, path: str | Path) -> None:
    """Lay the keys a config file sets over ``values`` (each replaces the value before it;
    the file's defaults do not) and check the limits in order on the result, each at the
    file's line of the key that breaks it; raise ConfigError."""
    path = Path(path)
    text = _read(path)
    for section, keys in load_config_text(text, str(path), fill_defaults=False).items():
        values[section].update(keys)
    problems = order_problems(values, str(path), _locate_keys(text.splitlines()))
    if problems:
        raise ConfigError(problems)


def _read(path: Path) -> str:
    try:
        return path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError([ConfigProblem(str(path), None, "file", f"cannot read: {exc}")]) from exc


def order_problems(values: Values, path: str, where: dict[tuple[str, str], int],
                   orders: Sequence[Order] = ORDERS) -> list[ConfigProblem]:
    """Limits out of order (sections.ORDERS), each at the line of the key that breaks it."""
    def get(dotted: str) -> Any:
        section, key = dotted.split(".", 1)
        return values[section][key]

    problems = []
    for order in orders:
        problem = order.problem(get)
        if problem is not None:
            dotted, why = problem
            section, key = dotted.split(".", 1)
            problems.append(ConfigProblem(path, where.get((section, key)), dotted, why))
    return problems


def load_config_text(
    text: str,
    path: str = "<config>",
    *,
    fill_defaults: bool = True,
    sections: Mapping[str, Section] = SECTIONS,
) -> Values:
    """Parse and check TOML text; collect every problem before raising ConfigError."""
    problems: list[ConfigProblem] = []
    lines = text.splitlines()
    raw = _parse_tolerant(lines, path, problems)
    where = _locate_keys(lines)
    values: Values = defaults(sections) if fill_defaults else {}
    for section_name, table in raw.items():
        section = sections.get(section_name)
        if section is None:
            line = where.get((section_name, ""))
            problems.append(ConfigProblem(path, line, section_name, "unknown section"
                                          + _suggest(section_name, list(sections))))
            continue
        if not isinstance(table, dict):
            problems.append(ConfigProblem(path, where.get((section_name, "")), section_name,
                                          "expected a table [" + section_name + "]"))
            continue
        out = values.setdefault(section_name, {})
        for key, value in table.items():
            dotted = f"{section_name}.{key}"
            line = where.get((section_name, key))
            option = section.by_key.get(key)
            if option is None:
                problems.append(ConfigProblem(path, line, dotted, "unknown key"
                                              + _suggest(key, list(section.by_key))))
                continue
            checked, error = option.check(value)
            if error is not None:
                problems.append(ConfigProblem(path, line, dotted, error))
            else:
                out[key] = checked
    if fill_defaults and not problems and sections is SECTIONS:
        problems += order_problems(values, path, where)
    if problems:
        problems.sort(key=lambda p: (p.line is None, p.line or 0))
        raise ConfigError(problems)
    return values


def _parse_tolerant(lines: list[str], path: str, problems: list[ConfigProblem]) -> dict[str, Any]:
    """Parse TOML; on a syntax error, report it, blank that line and try again."""
    work = list(lines)
    for _ in range(_MAX_SYNTAX_ERRORS):
        try:
            return tomllib.loads("\n".join(work))
        except tomllib.TOMLDecodeError as exc:
            match = _SYNTAX_LINE.search(str(exc))
            message = _SYNTAX_LINE.sub("", str(exc)).strip()
            if match is None:
                # "at end of document": something opened (a list, a string) is never closed;
                # the last line with text is where the reader ran out.
                filled = [n for n, text in enumerate(work, start=1) if text.strip()]
                line = filled[-1] if filled else None
                key = _key_at(lines, line) if line is not None else "toml"
                problems.append(ConfigProblem(path, line, key, f"TOML syntax error: {message}"))
                return {}
            line_no = int(match.group(1))
            key = _key_at(lines, line_no)
            problems.append(ConfigProblem(path, line_no, key, f"TOML syntax error: {message}"))
            if line_no - 1 >= len(work) or work[line_no - 1] == "":
                return {}
            work[line_no - 1] = ""
    return {}


def _key_at(lines: list[str], line_no: int) -> str:
    """The ``section.key`` that a line belongs to, as well as can be told."""
    section = ""
    for index, line in enumerate(lines[:line_no]):
        header = _HEADER.match(line)
        if header and index < line_no - 1:
            section = header.group(1).strip().strip("\"'")
        elif header:
            return header.group(1).strip().strip("\"'") or "toml"
    key_match = _KEY.match(lines[line_no - 1]) if 0 < line_no <= len(lines) else None
    key = key_match.group(1).strip("\"'") if key_match else ""
    if section and key:
        return f"{section}.{key}"
    return section or key or "toml"


def _locate_keys(lines: list[str]) -> dict[tuple[str, str], int]:
    """Map (section, key) and (section, "") to the line they are on (1-based)."""
    where: dict[tuple[str, str], int] = {}
    section = ""
    for number, line in enumerate(lines, start=1):
        header = _HEADER.match(line)
        if header:
            section = header.group(1).strip().strip("\"'").split(".")[0]
            where.setdefault((section, ""), number)
            continue
        key_match = _KEY.match(line)
        if key_match:
            parts = [p.strip().strip("\"'") for p in key_match.group(1).split(".")]
            if section:
                where.setdefault((section, parts[0]), number)
            elif len(parts) >= 2:
                where.setdefault((parts[0], ""), number)
                where.setdefault((parts[0], parts[1]), number)
            else:
                where.setdefault((parts[0], ""), number)
    return where


def _suggest(word: str, known: list[str]) -> str:
    close = difflib.get_close_matches(word, known, n=1)
    if close:
        return f" (did you mean {close[0]!r}?)"
    return f" (known: {', '.join(sorted(known))})" if len(known) <= 12 else ""
