"""The patrol robot's simulator slice: its goals judged, the map drawn, its scenarios."""

from __future__ import annotations

from sim.nav.checks import NavCheck
from sim.slice import SimSlice

SIM = SimSlice(checks=(NavCheck(goals_key="patrol.goals"),))
