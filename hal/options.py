"""Typed config options with bounds and defaults, declared beside the code that reads them."""

from __future__ import annotations

import copy
import dataclasses
import functools
import itertools
import math
import re
import tomllib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from enum import Enum
from typing import TYPE_CHECKING, Any, TypeVar, get_args, get_origin, get_type_hints

if TYPE_CHECKING:
    from _typeshed import DataclassInstance


@dataclass(frozen=True, slots=True)
class ConfigProblem:
    """One problem of a config file: the file, the line (None: the file's), ``section.key``."""

    path: str
    line: int | None
    key: str
    message: str

    def __str__(self) -> str:
        where = f"{self.path}:{self.line}" if self.line is not None else self.path
        return f"{where}: {self.key}: {self.message}"


FileCheck = Callable[[dict[str, dict[str, Any]], str, dict[tuple[str, str], int]],
                     list[ConfigProblem]]
"""Checks the files a config points to: ``check(values, config_path, lines)`` where ``lines``
maps ``(section, key)`` (``(section, "")``: its header) to its line; the problems, if any."""


@dataclass(frozen=True, slots=True)
class Option:
    """One ``section.key``: its type, default, bounds and whether it can be tuned live.

    ``kind`` is one of ``bool``, ``int``, ``float``, ``str``, ``list[str]``, ``list[float]``,
    ``table`` (a free-form table, e.g. per-beacon settings).
    """

    key: str
    kind: str
    default: Any
    help: str
    min: float | None = None
    max: float | None = None
    choices: tuple[str, ...] | tuple[int, ...] | None = None
    tunable: bool = False
    required: bool = False
    unknown: str | None = None
    """What a value outside ``choices`` is called (``unknown profile 'x'``); the known values
    follow it. None: ``expected one of ...``."""
    pattern: tuple[str, str] | None = None
    """For ``str``: (regular expression the whole value must match, what that means)."""

    def check(self, value: Any) -> tuple[Any, str | None]:
        """Return (normalised value, None) or (None, what was expected)."""
        kind = self.kind
        if kind == "bool":
            if isinstance(value, bool):
                return value, None
            return None, f"expected true or false, got {_show(value)}"
        if kind == "int":
            if isinstance(value, bool) or not isinstance(value, int):
                return None, f"expected an integer, got {_show(value)}"
            if self.choices is not None and value not in self.choices:
                return None, f"expected one of {', '.join(map(str, self.choices))}, got {value}"
            return self._bounded(value)
        if kind == "float":
            if isinstance(value, bool) or not isinstance(value, int | float):
                return None, f"expected a number, got {_show(value)}"
            if not math.isfinite(value):
                # NaN passes every range check (all its comparisons are false).
                return None, f"expected a finite number, got {value}"
            return self._bounded(float(value))
        if kind == "str":
            if not isinstance(value, str):
                return None, f"expected a string, got {_show(value)}"
            if self.choices is not None and value not in self.choices:
                if self.unknown is not None:
                    known = ", ".join(map(str, self.choices))
                    return None, f"{self.unknown} {value!r} (known: {known})"
                return None, f"expected one of {', '.join(map(repr, self.choices))}, got {value!r}"
            if self.min is not None and len(value) < self.min:
                return None, f"expected at least {int(self.min)} characters"
            if self.pattern is not None and re.fullmatch(self.pattern[0], value) is None:
                return None, f"expected {self.pattern[1]}, got {value!r}"
            return value, None
        if kind == "list[str]":
            if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
                return None, f"expected a list of strings, got {_show(value)}"
            return list(value), None
        if kind == "list[float]":
            if not isinstance(value, list) or not all(
                isinstance(v, int | float) and not isinstance(v, bool) for v in value
            ):
                return None, f"expected a list of numbers, got {_show(value)}"
            if not all(math.isfinite(v) for v in value):
                return None, f"expected finite numbers, got {value!r}"
            return [float(v) for v in value], None
        if kind == "list[point]":  # [[x, y], ...] in metres
            ok = isinstance(value, list) and all(
                isinstance(p, list) and len(p) == 2 and all(
                    isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)
                    for v in p) for p in value)
            if not ok:
                return None, f"expected a list of [x, y] points, got {_show(value)}"
            return [[float(p[0]), float(p[1])] for p in value], None
        if kind == "table":
            if not isinstance(value, dict):
                return None, f"expected a table, got {_show(value)}"
            return value, None
        msg = f"unknown option kind {kind!r}"
        raise AssertionError(msg)

    def _bounded(self, value: float) -> tuple[Any, str | None]:
        if self.min is not None and value < self.min:
            return None, f"must be >= {_num(self.min)}, got {_num(value)}"
        if self.max is not None and value > self.max:
            return None, f"must be <= {_num(self.max)}, got {_num(value)}"
        return value, None

    def parse_text(self, text: str) -> tuple[Any, str | None]:
        """Parse a value typed on the command line (``robotctl tune set``) and check it."""
        try:
            value = tomllib.loads(f"v = {text}")["v"]
        except tomllib.TOMLDecodeError:
            try:  # what TOML spells only in lower case: NaN, Infinity, INF
                value = float(text)
            except ValueError:
                value = text  # a bare word is a string
        return self.check(value)


@dataclass(frozen=True, slots=True)
class Section:
    name: str
    help: str
    options: tuple[Option, ...]
    configs: tuple[type[DataclassInstance], ...] = field(default=(), repr=False, compare=False)
    """The dataclasses whose ``setting`` fields declare ``options`` (``section_of``), if any."""
    by_key: dict[str, Option] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "by_key", {o.key: o for o in self.options})


@dataclass(frozen=True, slots=True)
class Order:
    """Keys (``section.key``) whose values must rise in this order, e.g. a lower and an upper
    limit; ``strict``: no two alike."""

    keys: tuple[str, ...]
    strict: bool = True

    def problem(self, get: Callable[[str], Any], changed: str | None = None
                ) -> tuple[str, str] | None:
        """(key, why) for the first pair out of order, or None. ``get`` reads a key's value;
        the key named is ``changed`` when that one made the pair wrong, else the later one."""
        for low, high in itertools.pairwise(self.keys):
            lo, hi = get(low), get(high)
            if lo < hi or (lo == hi and not self.strict):
                continue
            word = "below" if self.strict else "at most"
            if changed == low:
                return low, f"must be {word} {high} ({_num(hi)}), got {_num(lo)}"
            word = "above" if self.strict else "at least"
            return high, f"must be {word} {low} ({_num(lo)}), got {_num(hi)}"
        return None


T = TypeVar("T")
C = TypeVar("C", bound="DataclassInstance")

_DECLARED = "hal.options.setting"
"""The key of a ``setting`` field's metadata."""


@dataclass(frozen=True, slots=True)
class _Declared:
    """What ``setting`` was told, less the key (the field's name) and the kind (its type)."""

    default: Any
    help: str
    min: float | None
    max: float | None
    choices: tuple[str, ...] | tuple[int, ...] | None
    tunable: bool
    required: bool
    unknown: str | None
    pattern: tuple[str, str] | None


def setting(default: T, help: str, *, min: float | None = None, max: float | None = None,
            choices: tuple[str, ...] | tuple[int, ...] | None = None, tunable: bool = False,
            required: bool = False, unknown: str | None = None,
            pattern: tuple[str, str] | None = None) -> T:
    """A dataclass field that is a config key: its name is the key, its type the kind.

    Args:
        default: the value when the file has none; an Enum member's value is the key's (its
            members' values are the choices unless ``choices`` says otherwise).
        help: one sentence for the example config and ``robotctl tune get``.
        min, max, choices, tunable, required, unknown, pattern: as ``Option``'s.
    """
    declared = _Declared(default, help, min, max, choices, tunable, required, unknown, pattern)
    metadata = {_DECLARED: declared}
    if isinstance(default, list | dict):
        return field(default_factory=lambda: copy.deepcopy(default), metadata=metadata)
    return field(default=default, metadata=metadata)


@dataclass(frozen=True, slots=True)
class _Key:
    """One ``setting`` field: its Option and how a checked value becomes the field's."""

    option: Option
    convert: Callable[[Any], Any]


def options_of(config: type[DataclassInstance]) -> tuple[Option, ...]:
    """The Options of a dataclass's ``setting`` fields, in the order they are declared."""
    return tuple(key.option for key in _keys(config))


def section_of(configs: type[DataclassInstance] | Sequence[type[DataclassInstance]], name: str,
               help: str) -> Section:
    """The config section ``name`` whose keys are the ``setting`` fields of ``configs`` (one
    dataclass, or several whose keys follow one another)."""
    configs = tuple(configs) if isinstance(configs, Sequence) else (configs,)
    options = tuple(option for config in configs for option in options_of(config))
    return Section(name, help, options, configs=configs)


def load(config: type[C], values: Mapping[str, Any], /, **derived: Any) -> C:
    """``config`` built from a section's checked values, each field from the key of its name.

    Args:
        config: a dataclass with ``setting`` fields.
        values: the section's values (``settings.section(name)``), already checked.
        derived: the dataclass's other fields (not config keys), e.g. one read from
            another section.
    """
    read = {key.option.key: key.convert(values[key.option.key]) for key in _keys(config)}
    return config(**read, **derived)


def is_setting(spec: dataclasses.Field[Any]) -> bool:
    """Whether a dataclass field was declared with ``setting``."""
    return _DECLARED in spec.metadata


@functools.cache
def _keys(config: type[DataclassInstance]) -> tuple[_Key, ...]:
    hints = get_type_hints(config)
    keys = []
    for spec in dataclasses.fields(config):
        if not is_setting(spec):
            continue
        declared: _Declared = spec.metadata[_DECLARED]
        kind, convert, choices = _kind(hints[spec.name], f"{config.__name__}.{spec.name}")
        default = declared.default
        if isinstance(default, Enum):
            default = default.value
        elif isinstance(default, tuple):
            default = list(default)
        option = Option(spec.name, kind, default, declared.help, min=declared.min,
                        max=declared.max, choices=declared.choices or choices,
                        tunable=declared.tunable, required=declared.required,
                        unknown=declared.unknown, pattern=declared.pattern)
        keys.append(_Key(option, convert))
    return tuple(keys)


_SCALARS: dict[Any, str] = {bool: "bool", int: "int", float: "float", str: "str"}
_ITEMS: dict[Any, str] = {str: "list[str]", float: "list[float]"}


def _kind(hint: Any, where: str) -> tuple[str, Callable[[Any], Any], tuple[str, ...] | None]:
    """(Option kind, checked value -> field value, choices) of a field's type."""
    if hint in _SCALARS:
        return _SCALARS[hint], _same, None
    if isinstance(hint, type) and issubclass(hint, Enum):
        values = tuple(member.value for member in hint)
        if all(isinstance(v, str) for v in values):
            return "str", hint, values
    origin, args = get_origin(hint), get_args(hint)
    if origin is list and len(args) == 1 and args[0] in _ITEMS:
        return _ITEMS[args[0]], list, None
    if origin is tuple and len(args) == 2 and args[1] is Ellipsis and args[0] in _ITEMS:
        return _ITEMS[args[0]], tuple, None
    if origin is dict and args[:1] == (str,):
        return "table", dict, None
    msg = (f"{where}: {hint!r} cannot be a config key (bool, int, float, str, a str Enum, "
           "list[str], list[float], their tuple[..., ...], or dict[str, ...])")
    raise TypeError(msg)


def _same(value: Any) -> Any:
    return value


def _show(value: Any) -> str:
    kinds = {bool: "a boolean", int: "an integer", float: "a number", str: "a string",
             list: "a list", dict: "a table"}
    return f"{kinds.get(type(value), type(value).__name__)} ({value!r})"


def _num(value: float) -> str:
    return f"{value:.12g}"
