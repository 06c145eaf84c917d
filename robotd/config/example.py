"""The commented example config (``systemd/robotd.toml``), written from the schema itself.

``robotd example-config > systemd/robotd.toml`` regenerates it after a section changes.
"""

from __future__ import annotations

import json
import textwrap
from collections.abc import Mapping
from typing import Any

from hal.options import Option, Section
from robotd.config.sections import SECTIONS

HEADER = """\
# robotd configuration: /etc/robotd/robotd.toml (robotd run --config PATH to use another).
#
# Every section and key robotd knows is listed below with its default. Unknown sections or
# keys are errors. Check a file with:   robotd check-config /etc/robotd/robotd.toml
# Keys marked "tunable" can be changed on a running robot:
#   robotctl tune set line_follow.kp 0.6 [--persist]
# --persist keeps the value in <state dir>/overrides.toml, which is loaded over this file.
# After editing this file: robotctl reload (or systemctl reload robotd); a file that does not
# validate is refused and the running config is kept.
"""

SET_IN_EXAMPLE = {"robot.name", "robot.profile", "serial.port"}
"""Keys written uncommented: the ones every robot sets."""


def render_example(sections: Mapping[str, Section] = SECTIONS) -> str:
    out = [HEADER]
    for section in sections.values():
        out.append(f"\n[{section.name}]\n# {section.help}\n")
        for option in section.options:
            out.append(_option(section.name, option))
    return "".join(out)


def _option(section: str, option: Option) -> str:
    facts = [option.kind]
    if option.choices:
        facts.append("one of " + ", ".join(map(str, option.choices)))
    if option.min is not None and option.kind in ("int", "float"):
        facts.append(f">= {option.min:g}")
    if option.max is not None and option.kind in ("int", "float"):
        facts.append(f"<= {option.max:g}")
    if option.tunable:
        facts.append("tunable")
    comment = "" if f"{section}.{option.key}" in SET_IN_EXAMPLE else "#"
    text = f"{option.help} ({'; '.join(facts)})"
    lines = textwrap.wrap(text, width=96, initial_indent="# ", subsequent_indent="#   ")
    return "\n".join(lines) + f"\n{comment}{option.key} = {_toml(option.default)}\n"


def _toml(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int | float):
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, list):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k} = {_toml(v)}" for k, v in value.items()) + "}"
    return repr(value)
