"""The parts of the simulator the daemon's command line offers, found by entry point.

The simulator sits above the daemon (DESIGN.md, "Layering rules"): it imports robotd, never the
other way round. ``robotd sim`` and a probe's ``--sim`` are its entries, so the simulator
plugs them in through the entry point group ``robotd.simulator`` (pyproject.toml):
``command`` (``robotd sim``'s arguments and run) and ``probe_devices`` (the simulated devices
a ``--sim`` probe reads). An installation without the simulator simply has no ``robotd sim``.
"""

from __future__ import annotations

from importlib.metadata import entry_points
from typing import Any

GROUP = "robotd.simulator"


def simulator_part(name: str) -> Any | None:
    """The simulator's part ``name`` (``command``, ``probe_devices``), or None when the
    simulator is not installed."""
    for entry in entry_points(group=GROUP, name=name):
        return entry.load()
    return None
