"""What behaviours and drivers see of the running config: read and watch dotted keys."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol, runtime_checkable

SettingsListener = Callable[[str, Any], None]
"""Called with (dotted key, new value) when a watched key changes."""


@runtime_checkable
class SettingsView(Protocol):
    """The read side of ``robotd.config.Settings``; the daemon passes the real one in."""

    def get(self, dotted: str) -> Any: ...
    def section(self, name: str) -> dict[str, Any]: ...
    def watch(self, prefix: str, listener: SettingsListener) -> Callable[[], None]: ...
