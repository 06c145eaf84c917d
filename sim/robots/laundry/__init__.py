"""The laundry robot's simulator slice: its fleet server, customers and staff, its scenarios."""

from __future__ import annotations

from sim.robots.laundry.checks import LaundrySiteCheck
from sim.slice import SimSlice

SIM = SimSlice(actors="sim.robots.laundry.actors:LaundryActors.for_scenario",
               checks=(LaundrySiteCheck(),),
               scenario_tables={"fleet": ("site", "settings", "customers", "washing_s",
                                          "base_room", "unload_after_s", "slow_unloads",
                                          "slow_unload_s", "fetch_laundry_s", "hands")},
               runs_fleet=True)
