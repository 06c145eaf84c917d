"""The dock IR receivers' settings, read once from the ``docking`` config section."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

from drivers.dock_ir.oi_codes import CodeTable

RECEIVERS = ("omni", "front_left", "front_right", "side_left", "side_right", "rear")
"""The seed's receivers: omni (search), front pair (fine alignment), +-120 deg, rear."""

NOT_FITTED = -1


class SettingsView(Protocol):
    def get(self, dotted: str) -> Any: ...
    def watch(self, prefix: str, listener: Callable[[str, Any], None]) -> Callable[[], None]: ...


@dataclass(frozen=True, slots=True)
class DockIrConfig:
    """Which GPIO line each receiver is on, how to read them, and the code table."""

    lines: dict[str, int] = field(default_factory=dict)
    """Receiver name -> GPIO line, fitted receivers only."""
    gpiochip: int = 0
    active_low: bool = True
    tolerance: float = 0.25
    window_s: float = 0.2
    table: CodeTable = field(default_factory=CodeTable.build)

    @classmethod
    def from_settings(cls, settings: SettingsView) -> DockIrConfig:
        """Read ``docking.ir_*``; ValueError naming the key when they cannot work together."""
        lines: dict[str, int] = {}
        for receiver in RECEIVERS:
            gpio = int(settings.get(f"docking.ir_gpio_{receiver}"))
            if gpio == NOT_FITTED:
                continue
            other = next((r for r, g in lines.items() if g == gpio), None)
            if other is not None:
                msg = (f"docking.ir_gpio_{receiver}: GPIO {gpio} is already "
                       f"docking.ir_gpio_{other}")
                raise ValueError(msg)
            lines[receiver] = gpio
        if not lines:
            msg = f"docking.ir_gpio_*: no receiver has a GPIO line (all are {NOT_FITTED})"
            raise ValueError(msg)
        table = CodeTable.build(settings.get("docking.ir_codes"),
                                settings.get("docking.ir_combined"))
        return cls(lines=lines, gpiochip=int(settings.get("docking.ir_gpiochip")),
                   active_low=bool(settings.get("docking.ir_active_low")),
                   tolerance=float(settings.get("docking.ir_tolerance_pct")) / 100,
                   window_s=float(settings.get("docking.ir_window_s")), table=table)

