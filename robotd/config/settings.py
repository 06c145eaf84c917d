"""The running configuration: read by dotted key, tuned live, watched by the components."""

from __future__ import annotations

import copy
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from hal.options import Option
from robotd.config.screen import check_option
from robotd.config.sections import ORDERS, SECTIONS

Values = dict[str, dict[str, Any]]
Listener = Callable[[str, Any], None]


@dataclass(frozen=True, slots=True)
class Checked:
    """A value ``Settings.check`` accepted for ``key`` (normalised), for ``Settings.apply``."""

    key: str
    value: Any


class Settings:
    """Holds the checked config values; ``set`` validates like the file and tells listeners."""

    def __init__(self, values: Values, *, source: str = "<defaults>") -> None:
        self._values = copy.deepcopy(values)
        self.source = source
        self._listeners: list[tuple[str, Listener]] = []

    def get(self, dotted: str) -> Any:
        section, key = _split(dotted)
        try:
            return self._values[section][key]
        except KeyError:
            msg = f"{dotted}: unknown key"
            raise KeyError(msg) from None

    def section(self, name: str) -> dict[str, Any]:
        """A copy of one section's values."""
        return dict(self._values[name])

    def as_dict(self) -> Values:
        return copy.deepcopy(self._values)

    @staticmethod
    def option(dotted: str) -> Option:
        """The schema entry of a dotted key; KeyError with a message when unknown."""
        section, key = _split(dotted)
        try:
            return SECTIONS[section].by_key[key]
        except KeyError:
            msg = f"{dotted}: unknown key"
            raise KeyError(msg) from None

    def check(self, dotted: str, value: Any) -> Checked:
        """Validate a value for a key: its type and range (``check_option``: never an exception
        but ValueError for a bad value) and its order against the limits it pairs with.
        Returns it normalised, for ``apply``; ValueError says why not."""
        checked, error = check_option(self.option(dotted), value)
        if error is not None:
            msg = f"{dotted}: {error}"
            raise ValueError(msg)

        def get(key: str) -> Any:
            return checked if key == dotted else self.get(key)

        for order in ORDERS:
            if dotted in order.keys:
                problem = order.problem(get, changed=dotted)
                if problem is not None:
                    msg = f"{problem[0]}: {problem[1]}"
                    raise ValueError(msg)
        return Checked(dotted, checked)

    def apply(self, checked: Checked) -> Any:
        """Apply a value ``check`` returned (not checked again: apply it before anything
        else changes); listeners hear of it. Returns the value."""
        section, key = _split(checked.key)
        self._values[section][key] = checked.value
        for prefix, listener in list(self._listeners):
            if checked.key == prefix or checked.key.startswith(prefix + ".") or prefix == "":
                listener(checked.key, checked.value)
        return checked.value

    def set(self, dotted: str, value: Any) -> Any:
        """Validate and apply one value at once; listeners hear of it. Returns the value."""
        return self.apply(self.check(dotted, value))

    def replace(self, values: Values, *, source: str) -> list[str]:
        """Take a whole new config (a reload); tell listeners of each changed key."""
        changed = [
            f"{s}.{k}"
            for s, keys in values.items()
            for k, v in keys.items()
            if self._values.get(s, {}).get(k) != v
        ]
        self._values = copy.deepcopy(values)
        self.source = source
        for dotted in changed:
            value = self.get(dotted)
            for prefix, listener in list(self._listeners):
                if dotted == prefix or dotted.startswith(prefix + ".") or prefix == "":
                    listener(dotted, value)
        return changed

    def watch(self, prefix: str, listener: Listener) -> Callable[[], None]:
        """Call ``listener(key, value)`` when a key under ``prefix`` changes; returns unwatch."""
        entry = (prefix, listener)
        self._listeners.append(entry)

        def unwatch() -> None:
            if entry in self._listeners:
                self._listeners.remove(entry)

        return unwatch


def _split(dotted: str) -> tuple[str, str]:
    section, _, key = dotted.partition(".")
    if not section or not key:
        msg = f"{dotted!r}: expected section.key"
        raise KeyError(msg)
    return section, key
