"""The square robot's simulator slice: its scenarios (a square on wheel odometry)."""

from __future__ import annotations

from sim.slice import SimSlice

SIM = SimSlice()
