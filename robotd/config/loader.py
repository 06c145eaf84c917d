"""Load a TOML config file, check it against the schema, and say every problem with its line."""

from __future__ import annotations

import copy
import difflib
import json
import os
import re
import stat
import tomllib
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from behaviours.nav.map_file import map_problem
from hal.options import Order, Section
from robotd.config.errors import ConfigError, ConfigProblem
from robotd.config.screen import check_option, clip
from robotd.config.sections import ORDERS, SECTIONS
from robotd.config.system_limits import socket_path_problem
from robotd.profiles import PROFILES

Values = dict[str, dict[str, Any]]

_SYNTAX_LINE = re.compile(r"\(at line (\d+), column (\d+)\)")
# No two parts of these patterns can take the same characters: a hostile line (thousands of
# spaces after "[") is matched in linear time, not the cubic time of overlapping \s* runs.
_HEADER = re.compile(r"^[ \t]*\[\[?([^\[\]#]*)\]\]?[ \t]*(#.*)?$")
_HEADER_NAME = re.compile(r"[A-Za-z0-9_.\-\"' ]+")
_KEY_PART = r"""(?:"[^"\n]*"|'[^'\n]*'|[A-Za-z0-9_\-]+)"""
_KEY = re.compile(rf"^\s*({_KEY_PART}(?:[ \t]*\.[ \t]*{_KEY_PART})*)[ \t]*=")
_MAX_SYNTAX_ERRORS = 50
_PLAIN_NAME = re.compile(r"[A-Za-z0-9_\-]+")
_MAX_DEPTH = 100
MAX_CONFIG_BYTES = 1 << 20
"""A config file is a few kilobytes; past 1 MiB it is not one (or it is /dev/zero)."""
_LONG_NUMBER = re.compile(r"[0-9_]{4301,}")
_KINDS = {stat.S_IFDIR: "a directory", stat.S_IFIFO: "a FIFO", stat.S_IFCHR: "a character device",
          stat.S_IFBLK: "a block device", stat.S_IFSOCK: "a socket"}


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


def load_config_and_overrides(path: str | Path, overrides: str | Path
                              ) -> tuple[Values, list[ConfigProblem]]:
    """``load_config(path)`` (ConfigError when the main file is bad) with the overrides file
    laid over it when that file is good; when it is not, its problems are returned and none of
    it is used: one bad key could leave a pair of limits half changed. A bad overrides file
    (written by ``tune set --persist``) never keeps the robot from starting."""
    values = load_config(path)
    if not Path(overrides).exists():
        return values, []
    laid = copy.deepcopy(values)
    try:
        lay_over(laid, overrides)
    except ConfigError as exc:
        return values, exc.problems
    return laid, []


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
    """The file's text: a regular file of at most MAX_CONFIG_BYTES of UTF-8; else ConfigError.

    Opened non-blocking so that a FIFO with no writer does not hang the caller; size and kind
    come from the open file, so what is checked is what is read."""
    def refuse(line: int | None, message: str) -> ConfigError:
        return ConfigError([ConfigProblem(str(path), line, "file", message)])

    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_NOCTTY)
    except OSError as exc:
        raise refuse(None, f"cannot read: {exc.strerror or exc}") from None
    try:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            kind = _KINDS.get(stat.S_IFMT(mode), "not a regular file")
            raise refuse(None, f"cannot read: {kind}, not a regular file")
        data = bytearray()
        while len(data) <= MAX_CONFIG_BYTES:
            chunk = os.read(fd, MAX_CONFIG_BYTES + 1 - len(data))
            if not chunk:
                break
            data += chunk
    except OSError as exc:
        raise refuse(None, f"cannot read: {exc.strerror or exc}") from None
    finally:
        os.close(fd)
    if len(data) > MAX_CONFIG_BYTES:
        raise refuse(None, f"cannot read: larger than {MAX_CONFIG_BYTES} bytes (1 MiB); "
                     "a config file is a few kilobytes")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        byte = bytes(data[exc.start:exc.start + 1])
        raise refuse(line, f"not UTF-8 text: byte {byte!r} at offset {exc.start}") from None


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
            problems.append(ConfigProblem(path, line, _shown(section_name), "unknown section"
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
                problems.append(ConfigProblem(path, line, f"{section_name}.{_shown(key)}",
                                              "unknown key"
                                              + _suggest(key, list(section.by_key))))
                continue
            checked, error = check_option(option, value)
            if error is not None:
                problems.append(ConfigProblem(path, line, dotted, error))
            else:
                out[key] = checked
    if fill_defaults and not problems and sections is SECTIONS:
        problems += order_problems(values, path, where)
        problems += _system_problems(values, path, where)
    if problems:
        problems.sort(key=lambda p: (p.line is None, p.line or 0))
        raise ConfigError(problems)
    return values


def _system_problems(values: Values, path: str, where: dict[tuple[str, str], int]
                     ) -> list[ConfigProblem]:
    """What the operating system would refuse later (the socket path's length), and a map
    file that does not parse (the daemon must not start with it)."""
    problems = []
    map_file = values.get("map", {}).get("file")
    if isinstance(map_file, str):
        why = map_problem(map_file, Path(path).parent)
        if why is not None:
            problems.append(ConfigProblem(path, where.get(("map", "file")), "map.file", why))
    for spec in PROFILES.specs():  # the files each robot's own config points to
        for check in spec.file_checks:
            problems += check(values, path, where)
    socket_path = values.get("control", {}).get("socket")
    if not isinstance(socket_path, str):
        return problems
    why = socket_path_problem(socket_path)
    if why is None:
        return problems
    return [*problems,
            ConfigProblem(path, where.get(("control", "socket")), "control.socket", why)]


def _parse_tolerant(lines: list[str], path: str, problems: list[ConfigProblem]) -> dict[str, Any]:
    """Parse TOML; on a syntax error, report it, blank that line and try again."""
    work = list(lines)
    for _ in range(_MAX_SYNTAX_ERRORS):
        try:
            return tomllib.loads("\n".join(work))
        except RecursionError:
            # tomllib parses nested arrays and inline tables recursively.
            line_no = _too_deep_line(work)
            problems.append(ConfigProblem(path, line_no, _key_at(lines, line_no or 1),
                                          "arrays or inline tables nested too deeply to read "
                                          f"(past {_MAX_DEPTH} levels on this line)"))
            return {}
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
        except ValueError as exc:
            # Not a TOMLDecodeError: Python's int-to-str digit limit (4300 digits), raised by
            # int() inside tomllib with no position. The line is the one with the long number.
            line_no, digits = _long_number(work)
            if line_no is None:
                problems.append(ConfigProblem(path, None, "toml", clip(f"cannot read: {exc}")))
                return {}
            problems.append(ConfigProblem(
                path, line_no, _key_at(lines, line_no),
                f"integer of {digits} digits is out of range (TOML integers are 64-bit)"))
            work[line_no - 1] = ""
    return {}


def _long_number(lines: list[str]) -> tuple[int | None, int]:
    """The first line with a number past the digit limit, and its length."""
    for number, text in enumerate(lines, start=1):
        found = _LONG_NUMBER.search(text)
        if found is not None:
            return number, len(found.group(0).replace("_", ""))
    return None, 0


def _too_deep_line(lines: list[str]) -> int | None:
    """The first line where ``[``/``{`` opened in values (not table headers) pass _MAX_DEPTH;
    strings are skipped roughly (enough to find the line, not to parse TOML)."""
    depth = 0
    for number, text in enumerate(lines, start=1):
        if depth == 0 and _header_name(text) is not None:
            continue
        quote = ""
        for char in text:
            if quote:
                quote = "" if char == quote else quote
            elif char in "\"'":
                quote = char
            elif char == "#":
                break
            elif char in "[{":
                depth += 1
                if depth > _MAX_DEPTH:
                    return number
            elif char in "]}":
                depth = max(0, depth - 1)
    return None


def _key_at(lines: list[str], line_no: int) -> str:
    """The ``section.key`` that a line belongs to, as well as can be told."""
    section = ""
    for index, line in enumerate(lines[:line_no]):
        header = _header_name(line)
        if header is not None and index < line_no - 1:
            section = header
        elif header is not None:
            return header or "toml"
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
        header = _header_name(line)
        if header is not None:
            section = header.split(".")[0]
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


def _header_name(line: str) -> str | None:
    """The table name of a ``[name]`` or ``[[name]]`` line, unquoted; None for other lines."""
    header = _HEADER.match(line)
    if header is None or not _HEADER_NAME.fullmatch(header.group(1)):
        return None
    return header.group(1).strip().strip("\"'")


def _shown(name: str) -> str:
    """A name the file gave, as a problem line can carry it: bare when it is a plain word,
    else quoted with its colons escaped (``""``, ``"a\\u003ab"``), so that the line still
    reads ``PATH:LINE: section.key: message``."""
    if _PLAIN_NAME.fullmatch(name):
        return name
    return json.dumps(name).replace(":", "\\u003a")


def _suggest(word: str, known: list[str]) -> str:
    same_but_case = [k for k in known if k.lower() == word.lower()]
    close = same_but_case or difflib.get_close_matches(word, known, n=1)
    if close:
        return f" (did you mean {close[0]!r}?)"
    return f" (known: {', '.join(sorted(known))})" if len(known) <= 12 else ""
