"""The robot vacuum's parts of the body: bumpers, wall sensor, charging contacts, dust bin.

A mixin of ``DiffDriveBody`` (which holds the state and the physics): the sensors read the
world at the body's pose (``sim.world.touch``, ``sim.world.dock``); the station stops
the body like a wall except at its pads; the bin fills while cleaning and empties only on the
pads with the station's suction on and the bin door (the box servo) open.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol

from sim.world import touch
from sim.world.floor_plan import World
from sim.world.geometry import Pose, distance_to_segments


class VacuumParams(Protocol):
    """The parts of ``BodyParams`` these read (a Protocol: body.py imports this module)."""

    @property
    def radius_m(self) -> float: ...
    @property
    def cleans(self) -> bool: ...
    @property
    def bin_fill_pct_per_m(self) -> float: ...
    @property
    def evac_pct_per_s(self) -> float: ...
    @property
    def bin_door_open_deg(self) -> int: ...


class VacuumParts:
    """What ``DiffDriveBody`` gains for docking and cleaning."""

    world: World
    params: VacuumParams
    servo_deg: int
    _bin_pct: float

    if TYPE_CHECKING:
        def sync(self) -> None: ...
        def _pose_now(self) -> Pose: ...

    def _now(self) -> Pose:
        self.sync()
        return self._pose_now()

    def bumpers(self) -> tuple[bool, bool]:
        """(left, right) bumper switches: pressed against a wall, the dock or a person."""
        return touch.bumpers(self.world, self._now(), self.params.radius_m)

    def wall_cm(self) -> float:
        """The right-side wall sensor's distance (its maximum when nothing is in range)."""
        return touch.wall_cm(self.world, self._now(), self.params.radius_m)

    def contact_mv(self) -> int:
        """The voltage across the charging contacts: 0 off the dock, the station's on it."""
        dock = self.world.dock
        if dock is None:
            return 0
        return dock.voltage_mv(self._now(), self.params.radius_m)

    @property
    def bin_pct(self) -> float:
        """How full the dust bin is (0-100 %)."""
        self.sync()
        return self._bin_pct

    @bin_pct.setter
    def bin_pct(self, value: float) -> None:
        self.sync()
        self._bin_pct = value

    @property
    def bin_door_open(self) -> bool:
        return self.servo_deg >= self.params.bin_door_open_deg

    def _dock_stops(self, x: float, y: float, new_x: float, new_y: float,
                    free_m: float) -> tuple[bool, bool, float]:
        """Whether the dock stops a step: (blocked, by its body (a bump), free distance).

        The station's body is an obstacle like a wall; its pads, in the middle of the face,
        hold a robot's nose without a bump (their springs)."""
        dock = self.world.dock
        assert dock is not None
        radius_m = self.params.radius_m
        body_new = distance_to_segments(dock.outline(), new_x, new_y)
        pads_new = distance_to_segments(dock.pads(), new_x, new_y)
        free_m = min(free_m, body_new - radius_m, pads_new - radius_m)
        if body_new < radius_m and body_new < distance_to_segments(dock.outline(), x, y):
            return True, True, -1.0
        if pads_new < radius_m and pads_new < distance_to_segments(dock.pads(), x, y):
            return True, False, -1.0
        return False, False, free_m

    def _dust(self, elapsed_s: float, moved_m: float, on_dock: bool) -> None:
        """The bin fills while cleaning; it empties only on the pads with the station's
        suction on and the bin door open."""
        p = self.params
        if p.cleans and not on_dock:
            self._bin_pct = min(100.0, self._bin_pct + moved_m * p.bin_fill_pct_per_m)
        dock = self.world.dock
        if (dock is not None and dock.suction and self.bin_door_open
                and dock.touching(self._pose_now(), p.radius_m)):
            self._bin_pct = max(0.0, self._bin_pct - elapsed_s * p.evac_pct_per_s)
