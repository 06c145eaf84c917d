"""What the dock IR receivers and the front strength say, as the seed's decisions.

Pure functions of readings, so each phase's choice can be tested from beam and signal inputs:
which position case (section 2), which side of the front beams (phase 2), which receiver is
stronger (phase 3).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from behaviours.docking.tables import DockTrigger
from hal.readings import DockIrReading, DockSignal

BEAM_ROLES = ("far_left", "far_right", "front_left", "front_right", "centre", "force_field")
FRONT_RECEIVERS = ("front_left", "front_right")
LOCATING = ("omni", "front_left", "front_right")
"""Receivers that tell where the robot is (which beams it stands in)."""



@dataclass(frozen=True, slots=True)
class BeamView:
    """A dock IR reading seen through the seed's beam roles.

    ``roles`` maps a seed beam (``front_left``) to the name the code table gives it
    (``red_buoy``); a beam counts for a role under either name.
    """

    reading: DockIrReading
    roles: Mapping[str, str]

    def sees(self, receiver: str, role: str) -> bool:
        beams = self.reading.beams.get(receiver, frozenset())
        return role in beams or self.roles.get(role, role) in beams

    def sees_any(self, receiver: str) -> bool:
        return any(self.sees(receiver, role) for role in BEAM_ROLES)

    def located(self, role: str) -> bool:
        """Whether the robot stands in ``role``'s beam (omni or a front receiver sees it)."""
        return any(self.sees(r, role) for r in LOCATING)

    def dock_seen(self) -> bool:
        """Any receiver sees any of the dock's beams."""
        return any(self.sees_any(r) for r in self.reading.beams)

    def front_sees(self) -> bool:
        return any(self.sees_any(r) for r in FRONT_RECEIVERS)

    def field_seen(self) -> bool:
        """Any receiver sees the dock's force field (OI 161): the seed's "Force Field"."""
        return any(self.sees(r, "force_field") for r in self.reading.beams)


def position_case(view: BeamView) -> str | None:
    """Section 2's scan: the trigger of the case the beams call for, None for none.

    Rear receiver only: ``rear_seen`` (rear docking is refused: turn round first). In a front
    beam, the centre beam or only the force field (next to the dock): ``front_seen``.
    Far-R: ``far_right_seen`` (left approach); Far-L: ``far_left_seen`` (right approach)."""
    if view.sees_any("rear") and not view.front_sees():
        return DockTrigger.REAR_SEEN
    if any(view.located(role) for role in ("front_left", "front_right", "centre")):
        return DockTrigger.FRONT_SEEN
    if view.located("force_field") and not view.located("far_left") \
            and not view.located("far_right"):
        # Next to the dock: alignment backs out to where it can align.
        return DockTrigger.FRONT_SEEN
    if view.located("far_right"):
        return DockTrigger.FAR_RIGHT_SEEN
    if view.located("far_left"):
        return DockTrigger.FAR_LEFT_SEEN
    return None


def front_case(view: BeamView) -> str | None:
    """Phase 2: ``front_both`` in the overlap (or the centre beam), ``front_left_only`` or
    ``front_right_only`` on one side, None in neither front beam."""
    left, right = view.located("front_left"), view.located("front_right")
    if (left and right) or view.located("centre"):
        return DockTrigger.FRONT_BOTH
    if left:
        return DockTrigger.FRONT_LEFT_ONLY
    if right:
        return DockTrigger.FRONT_RIGHT_ONLY
    return None


def skew_case(view: BeamView) -> str | None:
    """Section 2's front case: ``skew_left`` (Front-L only), ``skew_right`` (Front-R only),
    ``centered`` (both); a far beam counts as its side (after a turn from the rear)."""
    case = front_case(view)
    if case == DockTrigger.FRONT_BOTH or (case is None and view.located("force_field")):
        return DockTrigger.CENTERED
    if case == DockTrigger.FRONT_LEFT_ONLY or (case is None and view.located("far_left")):
        return DockTrigger.SKEW_LEFT
    if case == DockTrigger.FRONT_RIGHT_ONLY or (case is None and view.located("far_right")):
        return DockTrigger.SKEW_RIGHT
    return None


def signal_case(signal: DockSignal, balance_ratio: float) -> str:
    """Phase 3's compare: ``left_stronger``, ``right_stronger`` or ``balanced`` (L ~ R when
    they differ by at most ``balance_ratio`` of the stronger)."""
    left, right = signal.front_left, signal.front_right
    if abs(left - right) <= balance_ratio * max(left, right, 1):
        return DockTrigger.BALANCED
    return DockTrigger.LEFT_STRONGER if left > right else DockTrigger.RIGHT_STRONGER
