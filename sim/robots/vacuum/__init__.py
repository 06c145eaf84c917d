"""The robot vacuum's simulator slice: its docking scenarios.

The dock, its beams and the station are the world's, shared by every robot with dock IR
receivers."""

from __future__ import annotations

from sim.slice import SimSlice

SIM = SimSlice()
