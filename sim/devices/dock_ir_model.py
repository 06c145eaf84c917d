"""The robot's six dock IR receivers in the simulated world: the dock's beams -> pin edges.

Each emission slot of the dock (``sim.world.dock``), every receiver that the slot's beams
reach (inside the beam's sector and range, the dock's apex inside the receiver's field of view,
nothing in between) sees their codes, started on the same microsecond by the dock: the union
of their marks, i.e. the OR of their codes (``ir_emitter.union``). The receiver's own output
timing wobbles (``jitter_us``, a TSOP's demodulator), an edge can be lost (``drop_fraction``)
and a lamp can flicker (``spikes_per_s``): the decoder counts what that does.

``SimDockIr`` is the ``hal.ports.IrEdgeSource`` the real ``drivers.dock_ir`` device reads: it
works out a slot's frames when the slot starts and wakes the loop once per slot, at its end,
handing over the whole frame (never a wake-up per edge). ``strengths()`` gives the two front
receivers' analog signal strength (10-bit), which the motor board reports as ``IRS``.
"""

from __future__ import annotations

import asyncio
import bisect
import math
import random
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from hal.ports import IrEdge
from sim.devices.ir_emitter import Marks, SimIrEdgeSource, code_marks, spikes, to_edges, union
from sim.world.dock import Beam, Dock
from sim.world.geometry import Pose, wrap_angle

if TYPE_CHECKING:
    from sim.world.body import DiffDriveBody


@dataclass(frozen=True, slots=True)
class Mount:
    """Where a receiver sits on the robot and where it looks (robot frame)."""

    name: str
    rim_deg: float  # where on the rim (0: the nose, +: left)
    look_deg: float  # the middle of its field of view
    half_fov_deg: float


MOUNTS: tuple[Mount, ...] = (
    Mount("omni", 0.0, 0.0, 180.0),  # on top, at the front: sees all round
    # The front pair is crossed (each looks a little across the nose, behind a divider), so
    # that, as the seed's alignment wants, L > R means the dock lies to the right.
    Mount("front_left", 15.0, -10.0, 35.0),
    Mount("front_right", -15.0, 10.0, 35.0),
    Mount("side_left", 120.0, 120.0, 60.0),
    Mount("side_right", -120.0, -120.0, 60.0),
    Mount("rear", 180.0, 180.0, 45.0),
)
"""The seed's receivers: omni (search), front x2 (fine alignment), +-120 deg (wide), rear."""

OMNI_FORWARD_M = 0.12  # the omni receiver's mast, behind the bumper
STRENGTH_FULL_M = 0.2  # a beam's centre read head-on from this close saturates the ADC
STRENGTH_MAX = 1023


class SimDockIr(SimIrEdgeSource):
    """The receivers' GPIO lines, fed by the world's dock at the body's pose.

    Args:
        body: the robot (pose, radius, other robots that shade the beams).
        receivers: the receivers fitted (the driver's ``docking.ir_gpio_*`` not -1).
        rng: for the receivers' jitter, lost edges and noise.
        jitter_us: each edge's timing error, uniform within +-this.
        drop_fraction: the share of edges the kernel misses.
        spikes_per_s: short noise marks per receiver per second.
    """

    def __init__(self, body: DiffDriveBody, *, receivers: tuple[str, ...] | None = None,
                 rng: random.Random | None = None, jitter_us: int = 60,
                 drop_fraction: float = 0.0, spikes_per_s: float = 0.0,
                 clock_s: Callable[[], float] | None = None) -> None:
        super().__init__(clock_s=clock_s)
        self.body = body
        wanted = receivers if receivers is not None else tuple(m.name for m in MOUNTS)
        self.mounts = tuple(m for m in MOUNTS if m.name in wanted)
        self.rng = rng or random.Random(0)
        self.jitter_us = jitter_us
        self.drop_fraction = drop_fraction
        self.spikes_per_s = spikes_per_s
        self._next_slot: int | None = None  # the next slot (counted from t = 0) to work out
        self.frames = 0  # receiver-frames generated
        self.received: dict[str, set[str]] = {m.name: set() for m in self.mounts}
        """What each receiver caught in the last slot it caught anything (for tests)."""
        self.unplugged: frozenset[str] = frozenset()
        """Receivers whose cable is out: their lines stay idle (no edges, not even noise)."""

    def unplug(self, receivers: tuple[str, ...] | None = None) -> None:
        """Pull the cable of these receivers (all when None): their edges stop."""
        names = {m.name for m in self.mounts}
        self.unplugged = self.unplugged | (names if receivers is None else set(receivers))

    def replug(self, receivers: tuple[str, ...] | None = None) -> None:
        """Plug these receivers (all when None) back in."""
        self.unplugged = frozenset() if receivers is None else self.unplugged - set(receivers)

    @property
    def dock(self) -> Dock | None:
        return self.body.world.dock

    # --- IrEdgeSource -----------------------------------------------------------------------
    async def next_edges(self) -> list[IrEdge]:
        while True:
            now_us = self.now_us()
            self.emit_due(now_us)
            ready = bisect.bisect_right(self._times, now_us)
            if ready:
                batch = self._pending[:ready]
                del self._pending[:ready], self._times[:ready]
                self.batches += 1
                self.edges += len(batch)
                return batch
            dock = self.dock
            if dock is None:
                self._wake.clear()
                await self._wake.wait()  # no dock, no light: only pushed edges (tests)
                continue
            slot_us = round(dock.slot_s * 1e6)
            # Wake when the slot under way has ended: its frames are then complete.
            wake_us = (now_us // slot_us + 1) * slot_us
            if self._pending:
                wake_us = max(wake_us, self._times[-1])
            await asyncio.sleep((wake_us - now_us) / 1e6 + 1e-6)

    # --- the light --------------------------------------------------------------------------
    def emit_due(self, now_us: int) -> None:
        """Queue the edges of every slot that has started by ``now_us``."""
        dock = self.dock
        if dock is None:
            return
        slot_us = round(dock.slot_s * 1e6)
        current = now_us // slot_us
        if self._next_slot is None or current - self._next_slot > 2 * dock.slots:
            self._next_slot = current  # first call, or the reader stalled: no backlog
        edges: list[IrEdge] = []
        while self._next_slot <= current:
            slot = self._next_slot
            edges += self.slot_edges(dock, slot % dock.slots, slot * slot_us)
            self._next_slot += 1
        if edges:
            self.push(edges)

    def slot_edges(self, dock: Dock, slot: int, t0_us: int) -> list[IrEdge]:
        """Every fitted receiver's edges for one emission slot starting at ``t0_us``."""
        pose = self.body.pose
        blockers = self._blockers()
        walls = self.body.world.walls
        slot_us = round(dock.slot_s * 1e6)
        out: list[IrEdge] = []
        for mount in self.mounts:
            if mount.name in self.unplugged:
                continue
            x, y = self.position(pose, mount)
            beams = [b for b in dock.beams_reaching(slot, x, y, walls, blockers)
                     if _in_view(pose, mount, x, y, b.apex(dock.pose))]
            marks: Marks = []
            if beams:
                self.received[mount.name] = {b.name for b in beams}
                self.frames += 1
                marks = union(*(code_marks(b.code, t0_us)[0] for b in beams))
            if self.spikes_per_s and self.rng.random() < self.spikes_per_s * dock.slot_s:
                marks = union(marks, spikes(t0_us, t0_us + slot_us, 1, rng=self.rng))
            if marks:
                out += self._damage(to_edges(self._jittered(marks), mount.name))
        return out

    def position(self, pose: Pose, mount: Mount) -> tuple[float, float]:
        return receiver_position(pose, mount, self.body.params.radius_m)

    def strengths(self) -> tuple[int, int]:
        """(front_left, front_right) signal strength, 0-1023 (``dock_signal``)."""
        return dock_signal(self.body)

    # --- helpers ----------------------------------------------------------------------------
    def _blockers(self) -> list[tuple[float, float, float]]:
        return _blockers(self.body)

    def _jittered(self, marks: Marks) -> Marks:
        if not self.jitter_us:
            return marks
        j, rng = self.jitter_us, self.rng
        out: Marks = []
        for start, end in marks:
            s = start + rng.randint(-j, j)
            e = max(s + 1, end + rng.randint(-j, j))
            if out and s <= out[-1][1]:
                s = out[-1][1] + 1
                e = max(e, s + 1)
            out.append((s, e))
        return out

    def _damage(self, edges: list[IrEdge]) -> list[IrEdge]:
        if not self.drop_fraction:
            return edges
        return [e for e in edges if self.rng.random() >= self.drop_fraction]


def receiver_position(pose: Pose, mount: Mount, radius_m: float) -> tuple[float, float]:
    """Where a receiver is in the world, for a robot of this radius at this pose."""
    if mount.name == "omni":
        return pose.to_world(OMNI_FORWARD_M, 0.0)
    angle = math.radians(mount.rim_deg)
    return pose.to_world(radius_m * math.cos(angle), radius_m * math.sin(angle))


def dock_signal(body: DiffDriveBody) -> tuple[int, int]:
    """(front_left, front_right): the front receivers' signal strength, 0-1023 (``IRS``).

    The strongest beam that reaches each (the board samples the envelope's peak over the
    dock's cycle): the beam's lobe times the receiver's (each cos^2, 1 on the axis, 0 at
    the edge) times an inverse-square fall-off, saturating at 1023."""
    dock = body.world.dock
    if dock is None:
        return 0, 0
    pose = body.pose
    blockers = _blockers(body)
    out = []
    for name in ("front_left", "front_right"):
        mount = next(m for m in MOUNTS if m.name == name)
        x, y = receiver_position(pose, mount, body.params.radius_m)
        peak = 0.0
        for slot in range(dock.slots):
            for beam in dock.beams_reaching(slot, x, y, body.world.walls, blockers):
                peak = max(peak, _strength(dock, beam, pose, mount, x, y))
        out.append(min(STRENGTH_MAX, round(STRENGTH_MAX * peak)))
    return out[0], out[1]


def _blockers(body: DiffDriveBody) -> list[tuple[float, float, float]]:
    """What shades a beam: people, other robots (circles x, y, radius)."""
    circles = [(p.x_m, p.y_m, p.radius_m) for p in body.world.people if p.present]
    for other in body.others:
        o = other.pose
        circles.append((o.x_m, o.y_m, other.params.radius_m))
    return circles


def _in_view(pose: Pose, mount: Mount, x_m: float, y_m: float,
             source: tuple[float, float]) -> bool:
    """Whether a source lies within a receiver's field of view."""
    if mount.half_fov_deg >= 180:
        return True
    return abs(_off_axis(pose, mount, x_m, y_m, source)) <= math.radians(mount.half_fov_deg)


def _off_axis(pose: Pose, mount: Mount, x_m: float, y_m: float,
              source: tuple[float, float]) -> float:
    bearing = math.atan2(source[1] - y_m, source[0] - x_m)
    return wrap_angle(bearing - pose.heading_rad - math.radians(mount.look_deg))


def _strength(dock: Dock, beam: Beam, pose: Pose, mount: Mount, x_m: float,
              y_m: float) -> float:
    apex = beam.apex(dock.pose)
    off_rx = _off_axis(pose, mount, x_m, y_m, apex)
    if abs(off_rx) > math.radians(mount.half_fov_deg):
        return 0.0
    distance = math.hypot(x_m - apex[0], y_m - apex[1])
    if beam.half_angle_deg >= 180:
        lobe = 1.0
    else:
        out_dir = math.atan2(y_m - apex[1], x_m - apex[0])
        off_beam = wrap_angle(out_dir - dock.heading_rad - math.radians(beam.centre_deg))
        lobe = math.cos(off_beam / math.radians(beam.half_angle_deg) * math.pi / 2) ** 2
    falloff = min(1.0, (STRENGTH_FULL_M / max(distance, 1e-3)) ** 2)
    rx_lobe = math.cos(off_rx / math.radians(mount.half_fov_deg) * math.pi / 2) ** 2
    return lobe * rx_lobe * falloff
