"""Values screened before an option checks them: what no option can hold is refused here.

``Option.check`` (schema.py) compares, converts and prints values. Some values that TOML and
JSON decode break those steps instead of failing them: an integer too large for a float
(``OverflowError`` in a comparison with a float bound or in ``f"{v:.12g}"``), one past Python's
int-to-str digit limit (``ValueError`` from ``repr``), or lists nested so deep that printing
them recurses. These functions refuse such values first, with a message, and turn whatever else
the check raises into a message too, so a caller never sees an exception for a bad value.
"""

from __future__ import annotations

import math
import tomllib
from typing import Any

from hal.options import Option

INT64_MIN = -(2**63)
INT64_MAX = 2**63 - 1
MAX_DEPTH = 8
"""No option holds lists or tables nested deeper (a table of per-beacon lists is 3)."""
MAX_TEXT_CHARS = 4096
MAX_MESSAGE_CHARS = 300
"""A message quoting a huge value is cut here: one line per problem stays readable."""


def screen_value(value: Any) -> str | None:
    """Why no option can hold ``value`` (an integer out of TOML's 64-bit range, nesting
    deeper than MAX_DEPTH), or None."""
    stack: list[tuple[Any, int]] = [(value, 0)]
    while stack:
        item, depth = stack.pop()
        if isinstance(item, int) and not isinstance(item, bool):
            if not INT64_MIN <= item <= INT64_MAX:
                return (f"integer out of range: about {_digits(item)} digits; "
                        f"at most {INT64_MAX} either way (64-bit)")
            continue
        if isinstance(item, dict | list):
            if depth >= MAX_DEPTH:
                return f"nested deeper than {MAX_DEPTH} levels"
            children = item.values() if isinstance(item, dict) else item
            stack.extend((child, depth + 1) for child in children)
    return None


def check_option(option: Option, value: Any) -> tuple[Any, str | None]:
    """``option.check(value)`` that never raises: (value, None) or (None, why)."""
    problem = screen_value(value)
    if problem is not None:
        return None, problem
    try:
        checked, error = option.check(value)
    except (ArithmeticError, ValueError, RecursionError) as exc:
        return None, f"cannot be checked: {exc}"
    return checked, None if error is None else clip(error)


def read_option_text(text: str) -> tuple[Any, str | None]:
    """A value typed on robotctl's command line, read as ``Option.parse_text`` reads it (a
    TOML value, else a float such as ``NaN``, else a bare word) but not checked: (value, None)
    or (None, why it cannot be read); never raises. The reading is repeated here because
    ``parse_text`` checks at once, before the value could be screened."""
    if len(text) > MAX_TEXT_CHARS:
        return None, f"value too long ({len(text)} characters, at most {MAX_TEXT_CHARS})"
    value: Any
    try:
        value = tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        try:
            value = float(text)
        except ValueError:
            value = text
    except (ValueError, RecursionError) as exc:  # digit limit, deep nesting
        return None, clip(f"cannot be read: {exc}")
    return value, None


def clip(message: str) -> str:
    if len(message) <= MAX_MESSAGE_CHARS:
        return message
    return message[: MAX_MESSAGE_CHARS - 1] + "…"


def _digits(value: int) -> int:
    """Decimal digits of ``value``; past 3000 digits estimated from its bits (converting it
    to text would hit the int-to-str digit limit)."""
    bits = abs(value).bit_length()
    if bits <= 10_000:
        return len(str(abs(value)))
    return math.floor((bits - 1) * math.log10(2)) + 1
