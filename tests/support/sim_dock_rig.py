"""A simulated rig with the dock IR receivers in front of a dock, for the simulator's dock tests."""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from typing import Any

from hal.readings import DockIrReading
from sim.actions import Step
from sim.config import robot_settings
from sim.rig import SimRig, open_sim_rig
from sim.scenario import Scenario
from sim.world.body import DiffDriveBody
from sim.world.geometry import Pose

DOCK_SCENARIO = """
[scenario]
name = "dock-test"
profile = "square"

[config.docking]
ir_combined = ["force_field", "front_left", "front_right"]

[config.docking.ir_codes]
force_field = 161
front_left = 168
front_right = 164
far_left = 184
far_right = 180
centre = 176

[world]
width_m = 6.0
height_m = 4.0
dock = { x_m = 0.14, y_m = 2.0, heading_deg = 0 }

[robot]
name = "vac"
x_m = 1.0
y_m = 2.0
heading_deg = 180

[success]
time_limit_s = 10
"""
"""A 6 x 4 m room, the dock on the left wall, the robot 0.86 m out on its axis facing it."""


async def dock_rig(scenario: Scenario, needs: tuple[str, ...] = ("dock_ir",)) -> SimRig:
    """The scenario's first robot's simulated devices (``needs``), on the real drivers."""
    spec = scenario.robots[0]
    settings = robot_settings(scenario, spec, None)
    body = DiffDriveBody(scenario.world, Pose(spec.x_m, spec.y_m, spec.heading_rad),
                         clock=asyncio.get_running_loop().time)
    return await open_sim_rig(scenario.world, body, settings, seed=1, index=0, needs=needs)


def script_step(scenario: Scenario, rig: SimRig, **args: Any) -> Step:
    """A script step for the robot ``vac`` with ``args``; timed ends run on the loop."""
    def later(delay_s: float, fn: Callable[[], None], _name: str) -> None:
        asyncio.get_running_loop().call_later(delay_s, fn)

    return Step(scenario, "vac", rig, args, later)


async def reading_after(rig: SimRig, seconds: float) -> DockIrReading:
    """The dock IR driver's reading ``seconds`` of virtual time from now."""
    device = rig.devices.dock_ir
    assert device is not None
    loop = asyncio.get_running_loop()
    end = loop.time() + seconds
    reading = await device.next_reading()
    while loop.time() < end:
        reading = await device.next_reading()
    return reading
