"""The patrol robot: drives a route of goals on a map with LiDAR localisation (issue 16)."""

from __future__ import annotations

from behaviours.nav.zones import zone_file_problems
from behaviours.profile import ProfileSpec
from behaviours.profiles.patrol.profile import PATROL, PatrolProfile

SPEC = ProfileSpec(
    PatrolProfile,
    "drives a route of map goals on its LiDAR-localised pose, replanning around what the map "
    "lacks and keeping out of its zones; a lost pose is found again over the whole map",
    sections=(PATROL,),
    file_checks=(zone_file_problems,),  # the map section's masks (every navigating robot's)
)
