"""Tuning made with ``robotctl tune set --persist``: a small TOML file in the state directory.

It is loaded over the main config file at start; writes replace it atomically (write to a
temporary file, fsync, rename), so a power cut leaves the old file or the new one.
"""

from __future__ import annotations

import os
import tomllib
from pathlib import Path
from typing import Any

OVERRIDES_NAME = "overrides.toml"
_HEADER = "# Written by robotd (robotctl tune set --persist); loaded over the main config.\n"


def overrides_path(state_dir: str | Path) -> Path:
    return Path(state_dir) / OVERRIDES_NAME


def read_overrides(path: Path) -> dict[str, dict[str, Any]]:
    if not path.exists():
        return {}
    with path.open("rb") as handle:
        data = tomllib.load(handle)
    return {s: dict(keys) for s, keys in data.items() if isinstance(keys, dict)}


def persist_override(path: Path, dotted: str, value: Any) -> None:
    """Set one ``section.key`` in the overrides file, atomically."""
    section, _, key = dotted.partition(".")
    data = read_overrides(path)
    data.setdefault(section, {})[key] = value
    write_atomically(path, render_toml(data))


def render_toml(data: dict[str, dict[str, Any]]) -> str:
    """TOML for tables of scalars and lists (what config values are)."""
    out = [_HEADER]
    for section in sorted(data):
        out.append(f"\n[{section}]\n")
        for key in sorted(data[section]):
            out.append(f"{key} = {_value(data[section][key])}\n")
    return "".join(out)


def _value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int | float):
        return repr(value)
    if isinstance(value, str):
        try:
            value.encode("utf-8")
        except UnicodeEncodeError:
            msg = f"{value!r} is not valid Unicode text"
            raise ValueError(msg) from None
        return toml_string(value)
    if isinstance(value, list):
        return "[" + ", ".join(_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{toml_string(k)} = {_value(v)}" for k, v in value.items()) + "}"
    msg = f"cannot write {type(value).__name__} to TOML"
    raise TypeError(msg)


def toml_string(text: str) -> str:
    """A TOML basic string: quotes and backslashes escaped, control characters as \\uXXXX."""
    out = ['"']
    for char in text:
        if char in ('"', "\\"):
            out.append("\\" + char)
        elif ord(char) < 0x20 or ord(char) == 0x7F:
            out.append(f"\\u{ord(char):04x}")
        else:
            out.append(char)
    out.append('"')
    return "".join(out)


def write_atomically(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    with tmp.open("w", encoding="utf-8") as handle:
        handle.write(text)
        handle.flush()
        os.fsync(handle.fileno())
    os.replace(tmp, path)
    directory = os.open(path.parent, os.O_RDONLY)
    try:
        os.fsync(directory)
    finally:
        os.close(directory)
