"""The charging dock in the simulated world: its pose, body, IR beams and charging contacts.

The dock's pose is the middle of its front face (where the charging contacts are) and the
direction that face looks (its beams go out that way). In the dock's own frame ``forward`` is
out of the face and ``left`` is the dock's left; the beams are named as a robot facing the
dock sees them (the seed's figure): ``front_left`` lies on the robot's left, the dock's right.

Beams are sectors (an apex on the face, a centre direction, a half-angle and a range), each
with an 8-bit code, time-multiplexed: each emission slot of ``slot_s`` the beams of one slot
index send their code together, starting on the same microsecond, so a receiver inside two
of them sees the union of their marks, which is the OR of their codes (the OI's home base:
red buoy + green buoy = 172). Walls and people occlude a beam (a straight line from the apex).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field, replace

from sim.world.geometry import FloatArray, Pose, segments_array, segments_crossed, wrap_angle

SLOT_S = 0.036
"""One emission slot: an OI frame (8 bits x 4 ms = 32 ms) and a 4 ms gap the decoder can tell
from any space inside a frame (its longest is 3.75 ms). Four slots make a 144 ms cycle: every
beam comes round within the driver's 0.2 s window."""
CONTACT_MV = 16_000  # the station's charging voltage on its contacts (14-19 V window)
FAULT_MV = 6_500  # what a dirty or shorted contact shows (dock.contacts_fault)


@dataclass(frozen=True, slots=True)
class Beam:
    """One IR beam: a sector from an apex on the dock's face, in the dock's frame."""

    name: str
    code: int
    centre_deg: float  # direction of the sector's middle; + is the dock's left
    half_angle_deg: float
    range_m: float
    apex_forward_m: float = 0.0
    apex_left_m: float = 0.0
    slot: int = 0

    def covers(self, dock_pose: Pose, x_m: float, y_m: float) -> bool:
        """Whether a point lies inside this beam's sector and range (occlusion aside)."""
        ax, ay = dock_pose.to_world(self.apex_forward_m, self.apex_left_m)
        dx, dy = x_m - ax, y_m - ay
        distance = math.hypot(dx, dy)
        if distance > self.range_m:
            return False
        if distance < 1e-9 or self.half_angle_deg >= 180:
            return True
        bearing = math.atan2(dy, dx) - dock_pose.heading_rad - math.radians(self.centre_deg)
        return abs(wrap_angle(bearing)) <= math.radians(self.half_angle_deg)

    def apex(self, dock_pose: Pose) -> tuple[float, float]:
        return dock_pose.to_world(self.apex_forward_m, self.apex_left_m)


DEFAULT_BEAMS: tuple[Beam, ...] = (
    # Slot 0 is the OI home base: force field, red and green buoy sent together, so where
    # they overlap a receiver reads their OR (165, 169, 172, 173).
    Beam("force_field", 161, 0.0, 180.0, 0.6, slot=0),
    Beam("front_left", 168, -9.0, 13.0, 2.5, slot=0),
    Beam("front_right", 164, 9.0, 13.0, 2.5, slot=0),
    # Wide and long, one side each, for the search; they overlap nothing of their own slot.
    Beam("far_left", 184, -50.0, 40.0, 4.0, apex_left_m=-0.10, slot=1),
    Beam("far_right", 180, 50.0, 40.0, 4.0, apex_left_m=0.10, slot=2),
    # Narrow and short, on the axis, for the last metre.
    Beam("centre", 176, 0.0, 3.0, 1.0, slot=3),
)
"""The seed's beams. Codes: the OI home base's for force field and buoys, 160 + 16 + the
side's buoy bit for the far beams, 176 for the centre (each code once)."""


@dataclass
class Dock:
    """The station: pose, beams, body (an obstacle) and contacts; mutable by the script."""

    x_m: float
    y_m: float
    heading_rad: float
    beams: tuple[Beam, ...] = DEFAULT_BEAMS
    slot_s: float = SLOT_S
    width_m: float = 0.34
    depth_m: float = 0.14
    contact_span_m: float = 0.14  # the face's middle, where the robot's nose meets the pads
    contact_spacing_m: float = 0.10  # between the two pads (and the robot's two contacts)
    pad_half_width_m: float = 0.02
    contact_travel_m: float = 0.012  # the pads' spring travel
    contact_mv: int = CONTACT_MV
    fault_mv: int = FAULT_MV
    emitting: bool = True  # dock.beams_off clears it
    contacts_fault: bool = False  # dock.contacts_fault sets it
    suction: bool = False  # the station's evacuation fan (EVAC:1 through the contacts)
    _outline: tuple[tuple[float, float, float], FloatArray] | None = field(
        default=None, init=False, repr=False, compare=False)

    @property
    def pose(self) -> Pose:
        return Pose(self.x_m, self.y_m, self.heading_rad)

    def move(self, x_m: float, y_m: float, heading_rad: float) -> None:
        self.x_m, self.y_m, self.heading_rad = x_m, y_m, heading_rad

    @property
    def slots(self) -> int:
        return 1 + max((b.slot for b in self.beams), default=0)

    def beams_in_slot(self, slot: int) -> tuple[Beam, ...]:
        return tuple(b for b in self.beams if b.slot == slot)

    def beam(self, name: str) -> Beam:
        for b in self.beams:
            if b.name == name:
                return b
        msg = f"no dock beam {name!r}"
        raise KeyError(msg)

    # --- the body ---------------------------------------------------------------------------
    def outline(self) -> FloatArray:
        """The station's body as segments: back, sides and the face either side of the pads.

        The face's middle (``contact_span_m``) is left out: a robot nosing in there is
        stopped by the pads' springs (``contact_blocks``), not by a bump."""
        key = (self.x_m, self.y_m, self.heading_rad)
        if self._outline is None or self._outline[0] != key:
            p = self.pose
            half, span = self.width_m / 2, self.contact_span_m / 2
            corners = [p.to_world(0.0, -half), p.to_world(-self.depth_m, -half),
                       p.to_world(-self.depth_m, half), p.to_world(0.0, half)]
            segs = [(*a, *b) for a, b in itertools.pairwise(corners)]
            segs += [(*p.to_world(0.0, half), *p.to_world(0.0, span)),
                     (*p.to_world(0.0, -span), *p.to_world(0.0, -half))]
            self._outline = (key, segments_array(segs))
        return self._outline[1]

    def face_depth_m(self, x_m: float, y_m: float) -> tuple[float, float]:
        """A point in the dock's frame: (forward of the face, left of the axis)."""
        c, s = math.cos(self.heading_rad), math.sin(self.heading_rad)
        dx, dy = x_m - self.x_m, y_m - self.y_m
        return c * dx + s * dy, -s * dx + c * dy

    def pads(self) -> FloatArray:
        """The face's middle, where the pads are, as one segment."""
        p, span = self.pose, self.contact_span_m / 2
        return segments_array([(*p.to_world(0.0, span), *p.to_world(0.0, -span))])

    # --- the contacts -----------------------------------------------------------------------
    def touching(self, robot: Pose, radius_m: float) -> bool:
        """Whether both of a robot's front contacts rest on the dock's pads.

        The robot's contacts sit on its nose, ``contact_spacing_m`` apart; each must be
        within a pad's half-width sideways and within the pads' spring travel in depth."""
        half = self.contact_spacing_m / 2
        for side in (-1.0, 1.0):
            cx, cy = robot.to_world(radius_m * math.cos(half / radius_m),
                                    side * radius_m * math.sin(half / radius_m))
            forward, left = self.face_depth_m(cx, cy)
            if not -self.contact_travel_m <= forward <= self.contact_travel_m:
                return False
            if abs(left - side * -half) > self.pad_half_width_m:
                # The robot faces the dock, so its left contact is on the dock's right pad.
                return False
        return True

    def voltage_mv(self, robot: Pose, radius_m: float) -> int:
        """The voltage across the robot's contacts: 0 off the pads."""
        if not self.touching(robot, radius_m):
            return 0
        return self.fault_mv if self.contacts_fault else self.contact_mv

    def charges(self, robot: Pose, radius_m: float) -> bool:
        """Whether the station charges a robot there (pads touched, no fault)."""
        return not self.contacts_fault and self.touching(robot, radius_m)

    def docked_pose(self, radius_m: float) -> Pose:
        """Where a robot of this radius sits when docked: nose on the pads, facing the dock."""
        x, y = self.pose.to_world(radius_m, 0.0)
        return Pose(x, y, wrap_angle(self.heading_rad + math.pi))

    # --- the beams --------------------------------------------------------------------------
    def beams_reaching(self, slot: int, x_m: float, y_m: float, walls: FloatArray,
                       blockers: list[tuple[float, float, float]]) -> list[Beam]:
        """The beams of ``slot`` whose light reaches a point (sector, range, line of sight).

        ``blockers`` are circles (x, y, radius): people, other robots."""
        if not self.emitting:
            return []
        out = []
        pose = self.pose
        for beam in self.beams:
            if beam.slot != slot or not beam.covers(pose, x_m, y_m):
                continue
            ax, ay = beam.apex(pose)
            if segments_crossed(walls, ax, ay, x_m, y_m):
                continue
            if any(_segment_hits_circle(ax, ay, x_m, y_m, c) for c in blockers):
                continue
            out.append(beam)
        return out

    def with_beams(self, beams: tuple[Beam, ...]) -> Dock:
        return replace(self, beams=beams)


def _segment_hits_circle(x1: float, y1: float, x2: float, y2: float,
                         circle: tuple[float, float, float]) -> bool:
    cx, cy, r = circle
    ex, ey = x2 - x1, y2 - y1
    length2 = ex * ex + ey * ey
    t = 0.0 if length2 == 0 else max(0.0, min(1.0, ((cx - x1) * ex + (cy - y1) * ey) / length2))
    return math.hypot(x1 + t * ex - cx, y1 + t * ey - cy) < r
