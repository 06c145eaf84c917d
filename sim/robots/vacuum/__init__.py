"""The robot vacuum's simulator slice: docking scenarios, virtual walls, success conditions.

The dock, its beams and the station are the world's, shared by every robot with dock IR
receivers; the virtual wall (``world.py``) is sent in the dock's cycle."""

from __future__ import annotations

from sim.robots.vacuum.checks import VacuumCheck
from sim.robots.vacuum.world import expand_virtual_wall
from sim.slice import SimSlice

SIM = SimSlice(checks=(VacuumCheck(),), world_parts=(expand_virtual_wall,))
