"""The square profile: a 1 m square on wheel odometry (a demonstration and a test)."""

from __future__ import annotations

from behaviours.profile import ProfileSpec
from behaviours.profiles.square.profile import SquareProfile

SPEC = ProfileSpec(SquareProfile, "drives a 1 m square on wheel odometry and comes back")
