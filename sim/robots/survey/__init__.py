"""The survey mode's simulator slice: its map judged, its hand-over, its scenarios.

The map it makes is judged against the world's true cells and its key poses against the true
ones; ``survey.handover`` restarts the robot as a profile that drives on that map; its
scenario is ``map-depot``."""

from __future__ import annotations

from sim.nav.checks import NavCheck
from sim.robots.survey.checks import MapCheck
from sim.robots.survey.handover import HANDOVER_ACTIONS
from sim.slice import SimSlice

SIM = SimSlice(checks=(MapCheck(), NavCheck(goals_key="patrol.goals")),
               actions=HANDOVER_ACTIONS)
