"""The dock IR receivers' settings, read once from the ``docking`` config section."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from drivers.dock_ir.oi_codes import CodeTable, table_problem
from hal.options import Option, Order
from hal.settings import SettingsView

RECEIVERS = ("omni", "front_left", "front_right", "side_left", "side_right", "rear")
"""The seed's receivers: omni (search), front pair (fine alignment), +-120 deg, rear."""

NOT_FITTED = -1

IR_RECEIVER_GPIOS = {"omni": 17, "front_left": 27, "front_right": 22, "side_left": 23,
                     "side_right": 24, "rear": 25}
"""The receivers' default BCM GPIO lines."""

IR_OPTIONS: tuple[Option, ...] = (
    Option("ir_window_s", "float", 0.2,
           "A dock IR code stays seen this long after it was decoded (OR over a window).",
           min=0.02, max=5, tunable=True),
    Option("ir_source", "str", "gpio",
           "Where the receivers' edges come from: gpio (lgpio alerts on ir_gpiochip's lines) "
           "or stream (T_US NAME LEVEL lines written to the named pipe ir_stream).",
           choices=("gpio", "stream")),
    Option("ir_stream", "str", "",
           "Named pipe of edges for ir_source = stream (drivers/dock_ir/edge_stream.py)."),
    Option("ir_gpiochip", "int", 0, "GPIO chip of the IR receivers (/dev/gpiochipN).",
           min=0, max=64),
    *(Option(f"ir_gpio_{receiver}", "int", gpio,
             f"GPIO line of the {receiver.replace('_', ' ')} IR receiver; -1: not fitted.",
             min=-1, max=511)
      for receiver, gpio in IR_RECEIVER_GPIOS.items()),
    Option("ir_active_low", "bool", True,
           "The receivers pull their output low while they see the carrier (TSOP-style)."),
    Option("ir_tolerance_pct", "float", 25.0, "Tolerance of each IR pulse width.",
           min=5, max=40),
    Option("ir_codes", "table", {"force_field": 161, "green_buoy": 164, "red_buoy": 168,
                                 "virtual_wall": 162},
           "Dock beam name -> 8-bit IR code (defaults: the iRobot OI home base, virtual "
           "wall); each code once."),
    Option("ir_combined", "list[str]", ["force_field", "green_buoy", "red_buoy"],
           "Beams whose codes OR into a combination code when a receiver is in several "
           "(OI: 161 | 164 = 165)."),
)
"""The receivers' options in the ``docking`` section (the docking behaviour adds its own)."""


class DistinctCodes(Order):
    """``docking.ir_codes`` with ``docking.ir_combined``: each code 0-255 and given once, the
    OR combinations included (a code twice would make two beams one). An Order, so that
    check-config runs it with the limits at the line of the key: the generic machinery has no
    per-value check (hal.options.Option would want a ``validate`` hook)."""

    def problem(self, get: Callable[[str], Any], changed: str | None = None
                ) -> tuple[str, str] | None:
        why = table_problem(get(self.keys[0]), get(self.keys[1]))
        return None if why is None else (self.keys[0], why)


IR_ORDERS = (DistinctCodes(("docking.ir_codes", "docking.ir_combined")),)


@dataclass(frozen=True, slots=True)
class DockIrConfig:
    """Which GPIO line each receiver is on, how to read them, and the code table."""

    lines: dict[str, int] = field(default_factory=dict)
    """Receiver name -> GPIO line, fitted receivers only."""
    gpiochip: int = 0
    source: str = "gpio"
    stream: str = ""
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
        source, stream = str(settings.get("docking.ir_source")), str(
            settings.get("docking.ir_stream"))
        if source == "stream" and not stream:
            msg = "docking.ir_stream: empty, but docking.ir_source = 'stream' needs a pipe"
            raise ValueError(msg)
        table = CodeTable.build(settings.get("docking.ir_codes"),
                                settings.get("docking.ir_combined"))
        return cls(lines=lines, gpiochip=int(settings.get("docking.ir_gpiochip")),
                   source=source, stream=stream,
                   active_low=bool(settings.get("docking.ir_active_low")),
                   tolerance=float(settings.get("docking.ir_tolerance_pct")) / 100,
                   window_s=float(settings.get("docking.ir_window_s")), table=table)

