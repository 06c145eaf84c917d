"""The simulated devices ``robotd probe DEVICE --sim`` reads through the real drivers.

A probe's ``--sim`` is an entry into the simulator, as ``robotd sim`` is: the probe imports
this module by name when (and only when) it is asked for (``robotd.probes.simulator``), so
nothing of the robot's runtime imports the simulator.
"""

from __future__ import annotations

import random
from collections.abc import Callable, Coroutine
from typing import Any

from drivers.ble_scanner import ScannerFactory
from hal.ports import SerialOpener
from sim import vclock
from sim.devices.ble_model import SimBleAir
from sim.devices.camera_model import CameraMount, SimCamera
from sim.devices.hx711_model import SimHx711Lines
from sim.devices.ld19 import SimLd19, walls
from sim.devices.sim_serial import SimSerialPorts
from sim.world.body import DiffDriveBody
from sim.world.floor_plan import PaintedLine, World
from sim.world.geometry import Pose, segments_array


def run_virtual(coro: Coroutine[Any, Any, int]) -> int:
    """Run a probe on the virtual-time loop: a simulated device's answer comes at once."""
    return int(vclock.run(coro))


def camera(colour: str, offset_m: float, width_px: int, height_px: int, fps: float
           ) -> SimCamera:
    """A camera 1 m along a painted line across a 4 x 4 m floor, ``offset_m`` to its left."""
    world = World(4.0, 4.0, segments_array([]),
                  lines=[PaintedLine("line", ((0.0, 2.0), (4.0, 2.0)), colour, 0.025)])
    body = DiffDriveBody(world, Pose(1.0, 2.0 + offset_m, 0.0))
    return SimCamera(world, body, CameraMount(width_px=width_px, height_px=height_px, fps=fps))


def ble_scanners(beacons: list[dict[str, Any]], keep: list[Any]) -> ScannerFactory:
    """BLE adverts of ``beacons`` in a 6 x 4 m room, heard from (2, 2); the air's task is
    appended to ``keep``."""
    world = World.from_table({"width_m": 6, "height_m": 4, "beacons": beacons})
    air = SimBleAir(DiffDriveBody(world, Pose(2.0, 2.0, 0.0)), rng=random.Random(1))
    keep.append(air)
    factory: ScannerFactory = air.scanner_factory()
    return factory


def ld19_ports(room: list[tuple[float, float, float, float]], model: str, port: str,
               corrupt_pct: float) -> SerialOpener:
    """A simulated LD19 in ``room`` (wall segments) on ``port``, ``corrupt_pct`` % bad bytes."""
    device = SimLd19(walls(room), model=model, seed=1)
    device.corrupt(corrupt_pct)
    ports = SimSerialPorts()
    ports.attach(port, device)
    return ports


def hx711_lines(weight_kg: Callable[[], float], sps: int) -> SimHx711Lines:
    """The HX711's DOUT/SCK lines, with ``weight_kg()`` on the cell."""
    return SimHx711Lines(weight_kg=weight_kg, sps=sps, rng=random.Random(1))
