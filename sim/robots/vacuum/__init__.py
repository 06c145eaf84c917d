"""The robot vacuum's simulator slice: its docking scenarios, the virtual wall they may put in
the world, and its success conditions.

The dock, its beams and the station are the world's, shared by every robot with dock IR
receivers."""

from __future__ import annotations

from sim.robots.vacuum.checks import VacuumCheck
from sim.robots.vacuum.world import expand_virtual_wall
from sim.slice import SimSlice

SIM = SimSlice(checks=(VacuumCheck(),), world_parts=(expand_virtual_wall,))
