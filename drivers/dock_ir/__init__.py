"""The dock IR receivers: edges on GPIO lines -> iRobot OI beam codes -> what each receiver sees.

``from_settings(settings)`` builds the device from the ``docking`` section (``robotd/hardware.py``
names it); the modules, one concern each: ``oi_codes`` (the code table), ``edge_decoder`` (one
receiver's edges -> codes), ``window`` (the OR over a short window), ``stats`` (counters),
``flipper`` (Flipper Zero ``.ir`` captures), ``gpio_edges`` (lgpio alerts on the Pi),
``edge_stream`` (edges written to a named pipe),
``receivers`` (the device).
"""

from __future__ import annotations

from collections.abc import Callable

from drivers.dock_ir.config import RECEIVERS, DockIrConfig
from drivers.dock_ir.receivers import DockIrReceivers
from hal.ports import IrEdgeSource
from hal.settings import SettingsView

__all__ = ["RECEIVERS", "DockIrConfig", "DockIrReceivers", "from_settings"]


def from_settings(settings: SettingsView,
                  open_source: Callable[[], IrEdgeSource] | None = None) -> DockIrReceivers:
    """The receivers from ``docking.ir_*``: on lgpio, or on a pipe of edges for
    ``ir_source = "stream"``, unless ``open_source`` is given."""
    cfg = DockIrConfig.from_settings(settings)
    if open_source is None and cfg.source == "stream":
        from drivers.dock_ir.edge_stream import stream_edges_opener

        open_source = stream_edges_opener(cfg.stream, tuple(cfg.lines))
    if open_source is None:
        from drivers.dock_ir.gpio_edges import lgpio_edges_opener

        open_source = lgpio_edges_opener(cfg.gpiochip, cfg.lines)
    device = DockIrReceivers(open_source, receivers=tuple(cfg.lines), table=cfg.table,
                             window_s=cfg.window_s, active_low=cfg.active_low,
                             tolerance=cfg.tolerance)
    settings.watch("docking.ir_window_s", device.apply_setting)
    return device
