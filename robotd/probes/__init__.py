"""``robotd probe DEVICE``: a technician's check of one real device through its real driver.

Each probe module provides ``add_arguments(parser)`` and ``async def run(args) -> int``; the
CLI builds one sub-command per entry here and imports the module only when it is used.
"""

from __future__ import annotations

import argparse
import asyncio
from collections.abc import Callable, Coroutine
from typing import Any

PROBES: dict[str, tuple[str, str]] = {
    "serial": ("robotd.probes.serial", "the Arduino motor board link: handshake, commands, RTT"),
    "lidar": ("robotd.probes.lidar", "the LD19 LiDAR: packets, scan rate, CRC errors"),
    "ble": ("robotd.probes.ble", "BLE iBeacons in range: MAC, UUID, major/minor, RSSI"),
    "camera": ("robotd.probes.camera", "the camera: frame rate and size, line detection"),
    "hx711": ("robotd.probes.hx711", "the HX711 load cell: raw counts, kg, noise"),
    "dockir": ("robotd.probes.dockir", "the dock IR receivers: codes per second, decode errors; "
               "--replay a Flipper .ir capture"),
}
"""Device name -> (module path, one-line description)."""


def run_standalone(prog: str, doc: str | None,
                   add_arguments: Callable[[argparse.ArgumentParser], None],
                   run: Callable[[argparse.Namespace], Coroutine[Any, Any, int]],
                   argv: list[str] | None = None) -> int:
    """``python -m robotd.probes.NAME``: the same probe without the ``robotd`` command.

    A probe with a ``--sim`` option runs on the virtual-time loop when it is given.
    """
    from robotd.logs import configure_logging

    parser = argparse.ArgumentParser(prog=prog, description=doc,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    add_arguments(parser)
    args = parser.parse_args(argv)
    configure_logging(level="warning")
    return run_probe(run, args)


def run_probe(run: Callable[[argparse.Namespace], Coroutine[Any, Any, int]],
              args: argparse.Namespace) -> int:
    """Run a probe: on the virtual-time loop with ``--sim`` (a simulated device needs no wall
    clock: the answer comes at once and the same every time; a bit-banged simulated HX711 on
    the real clock would lose reads to the interpreter's pauses), else on a real loop."""
    if getattr(args, "sim", False):
        return int(simulator().run_virtual(run(args)))
    return asyncio.run(run(args))


def simulator() -> Any:
    """The simulated devices a ``--sim`` probe reads (the simulator's ``probe_devices``,
    plugged in by entry point: robotd/extensions.py)."""
    from robotd.extensions import simulator_part

    devices = simulator_part("probe_devices")
    if devices is None:
        msg = "--sim: the simulator is not installed"
        raise SystemExit(msg)
    return devices
