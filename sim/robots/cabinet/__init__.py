"""The cabinet robot's simulator slice: site, doors, conditions, report layer, scenarios.

Its world is drawn from the JSON site map; its conditions are the cabinets in order and the
links broken and reset."""

from __future__ import annotations

from sim.nav.checks import NavCheck
from sim.robots.cabinet.actions import DOOR_ACTIONS
from sim.robots.cabinet.checks import CabinetCheck
from sim.robots.cabinet.report import draw_cabinet
from sim.robots.cabinet.site_world import expand_site_map
from sim.slice import SimSlice

SIM = SimSlice(
    checks=(NavCheck(), CabinetCheck()),
    layers=(draw_cabinet,),
    actions=DOOR_ACTIONS,
    world_parts=(expand_site_map,),
    scenario_files=("cabinet.map_file", "cabinet.task_file"),
)
