"""The idle profile: a robot with no hardware and no mission (boots, idles, obeys estop/resume)."""

from __future__ import annotations

from behaviours.profile import BaseProfile, ProfileSpec


class IdleProfile(BaseProfile):
    """A robot that needs no hardware and has no mission."""

    name = "idle"


SPEC = ProfileSpec(IdleProfile, "no hardware and no mission: boots, idles, obeys estop/resume")
