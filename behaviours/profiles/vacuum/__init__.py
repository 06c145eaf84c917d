"""The robot vacuum (seed ir-docking-flowcharts.md): cleans, checks its battery, docks."""

from __future__ import annotations

from behaviours.profile import ProfileSpec
from behaviours.profiles.vacuum.config import VACUUM
from behaviours.profiles.vacuum.profile import VacuumProfile
from behaviours.profiles.vacuum.schedule import schedule_problems

SPEC = ProfileSpec(
    VacuumProfile,
    "cleans (bounces on bumps, follows walls), checks its battery and below "
    "docking.battery_threshold_pct returns to its front-entry dock: charge, empty, undock",
    sections=(VACUUM,),
    file_checks=(schedule_problems,),
)
