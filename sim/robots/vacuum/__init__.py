"""The robot vacuum's simulator slice: docking scenarios, virtual walls, success conditions.

Its scenarios may put a virtual wall in the world.

The dock, its beams and the station are the world's, shared by every robot with dock IR
receivers."""

from __future__ import annotations

from sim.robots.vacuum.checks import VacuumCheck
from sim.robots.vacuum.world import expand_virtual_wall
from sim.slice import SimSlice

SIM = SimSlice(checks=(VacuumCheck(),), world_parts=(expand_virtual_wall,))
