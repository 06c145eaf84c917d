"""The survey mode's simulator slice: the map it makes judged against the world's true cells,
the hand-over to a profile that drives on that map, and its scenarios (``map-depot``)."""

from __future__ import annotations

from sim.nav.checks import NavCheck
from sim.robots.survey.checks import MapCheck
from sim.robots.survey.handover import HANDOVER_ACTIONS
from sim.slice import SimSlice

SIM = SimSlice(checks=(MapCheck(), NavCheck(goals_key="patrol.goals")),
               actions=HANDOVER_ACTIONS)
