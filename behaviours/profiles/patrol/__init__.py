"""The patrol robot: drives a route of goals on a map with LiDAR localisation (issue 16)."""

from __future__ import annotations

from behaviours.profile import ProfileSpec
from behaviours.profiles.patrol.profile import PATROL, PatrolProfile

SPEC = ProfileSpec(
    PatrolProfile,
    "drives a route of map goals on its LiDAR-localised pose, replanning around what the map "
    "lacks; a lost pose or LiDAR stops it in recovery",
    sections=(PATROL,),
)
