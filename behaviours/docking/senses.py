"""The devices a docking robot reads and drives, taken from the context once per phase.

``DockSenses`` gives each phase the newest readings without waiting (``None`` or a neutral
value before the first one), the dock IR device's health (lost when it stops publishing or
its lines fail), and the wheel moves.
"""

from __future__ import annotations

import asyncio
from collections.abc import Awaitable, Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import structlog

from behaviours.docking.beams import BeamView
from behaviours.docking.config import DockingConfig
from behaviours.motion.moves import Mover
from behaviours.motion.odometry import Odometry
from behaviours.persistence import MissionRecord, Persisted
from hal.devices import (
    Battery,
    BinSensor,
    BumperSensor,
    ContactSensor,
    DockIr,
    DockSignalSensor,
    DockStation,
    ServoBox,
    WallSensor,
)
from hal.readings import DockIrReading, DockSignal
from hal.tasks import cancel_and_wait
from hal.telemetry import Telemetry

if TYPE_CHECKING:
    from behaviours.context import RobotContext

log = structlog.get_logger(__name__)

EMPTY = DockIrReading()


class DockingUnavailable(RuntimeError):
    """The robot lacks a device docking needs; says which."""


DOCKED_RECORD = MissionRecord("docking.dock", 1, {"docked": False})
"""Whether the robot sits on its dock (kept across a restart: it carries on charging)."""


@dataclass
class DockingRun:
    """What one docking remembers between its phases (odometry frame)."""

    dock_dir_rad: float | None = None
    """The direction from the robot to the dock, as last measured."""
    scanned_at: tuple[float, float] | None = None
    moved_for_search_m: float = 0.0
    """After a beam that led nowhere: wall follow this far before heeding a beam again."""
    offset_rad: float = 0.0
    """How far the robot has turned off the dock's direction to cross into the overlap."""
    travel_left_m: float = 0.0
    align_checks: int = 0
    adjust_sign: float = 0.0
    adjust_rad: float = 0.0
    emptied: bool = False
    ir_errors: int = 0

    def reset(self) -> None:
        self.dock_dir_rad = None
        self.scanned_at = None
        self.moved_for_search_m = 0.0
        self.offset_rad = 0.0
        self.travel_left_m = 0.0
        self.align_checks = 0
        self.emptied = False


@dataclass
class DockSenses:
    """What docking reads (IR, strength, contacts, bumpers, wall, bin, battery) and moves."""

    dock_ir: DockIr
    mover: Mover
    config: DockingConfig
    signal_sensor: DockSignalSensor | None = None
    contacts: ContactSensor | None = None
    bumpers: BumperSensor | None = None
    wall: WallSensor | None = None
    bin: BinSensor | None = None
    battery: Battery | None = None
    station: DockStation | None = None
    servo: ServoBox | None = None
    run: DockingRun = field(default_factory=DockingRun)
    kept: Persisted | None = None

    async def set_docked(self, docked: bool) -> None:
        """Whether the robot is on its dock, made durable before the robot acts on it."""
        if self.kept is not None:
            await self.kept.update(docked=docked)

    @classmethod
    def from_ctx(cls, ctx: RobotContext, odometry: Odometry,
                 run: DockingRun | None = None, kept: Persisted | None = None) -> DockSenses:
        d = ctx.devices
        if d.dock_ir is None:
            msg = "docking needs the dock IR receivers (devices.dock_ir)"
            raise DockingUnavailable(msg)
        if d.motors is None:
            msg = "docking needs the wheels (devices.motors)"
            raise DockingUnavailable(msg)
        return cls(d.dock_ir, Mover(d.motors, odometry, ctx.settings),
                   DockingConfig.from_settings(ctx.settings), d.dock_signal, d.dock_contacts,
                   d.bumpers, d.wall, d.bin, d.battery, d.station, d.servo,
                   run if run is not None else DockingRun(), kept)

    # -- the dock IR ------------------------------------------------------------------------
    def view(self) -> BeamView:
        return BeamView(self.dock_ir.latest() or EMPTY, self.config.beam_roles)

    def ir_age_s(self) -> float:
        """How old the newest dock IR reading is (inf before the first)."""
        reading = self.dock_ir.latest()
        if reading is None:
            return float("inf")
        return asyncio.get_running_loop().time() - reading.t_s

    def ir_edges(self) -> int:
        """Edges the receivers have given so far, on all lines (a silent harness gives none)."""
        total = self.dock_ir.status().get("total", {})
        return int(total.get("edges", 0) or 0) if isinstance(total, dict) else 0

    def ir_trouble(self) -> str | None:
        """Why the dock IR device cannot be trusted now, or None."""
        status = self.dock_ir.status()
        if status.get("running") is False:
            return "dock IR receivers: not running"
        errors = int(status.get("line_errors", 0) or 0)
        if errors > self.run.ir_errors:
            return f"dock IR receivers: {status.get('last_error') or 'line error'}"
        age = self.ir_age_s()
        if age > self.config.ir_stale_s:
            return f"dock IR receivers: no reading for {age:.1f} s"
        return None

    # -- the motor board's senses -------------------------------------------------------------
    def dock_dir(self) -> float:
        """The dock's direction in the odometry frame, as last found (else straight ahead)."""
        if self.run.dock_dir_rad is None:
            return self.mover.heading_rad
        return self.run.dock_dir_rad

    def signal(self) -> DockSignal | None:
        return None if self.signal_sensor is None else self.signal_sensor.latest()

    def strength(self) -> int:
        """The stronger front receiver's reading (0 before the first)."""
        signal = self.signal()
        return 0 if signal is None else max(signal.front_left, signal.front_right)

    def contact_mv(self) -> int:
        reading = None if self.contacts is None else self.contacts.latest()
        return 0 if reading is None else reading.mv

    def bumped(self) -> bool:
        reading = None if self.bumpers is None else self.bumpers.latest()
        return reading is not None and reading.any

    def wall_cm(self) -> float | None:
        reading = None if self.wall is None else self.wall.latest()
        return None if reading is None else reading.distance_cm

    def bin_pct(self) -> float:
        reading = None if self.bin is None else self.bin.latest()
        return 0.0 if reading is None else reading.percent

    def battery_pct(self) -> float | None:
        reading = None if self.battery is None else self.battery.latest()
        return None if reading is None else reading.percent


def show_dock(telemetry: Telemetry, senses: DockSenses) -> None:
    """The live view's ``dock``: each receiver's beams and codes, the front strengths."""
    reading = senses.dock_ir.latest() or EMPTY
    signal = senses.signal()
    telemetry.sample(
        "dock", beams={r: sorted(b) for r, b in reading.beams.items()},
        codes={r: sorted(c) for r, c in reading.codes.items()},
        front_left=None if signal is None else signal.front_left,
        front_right=None if signal is None else signal.front_right,
        contact_mv=senses.contact_mv())


IDLE_S = 0.05
PhaseStep = Callable[["RobotContext", "DockSenses"], Awaitable[object]]
Handlers = Mapping[str, PhaseStep]
"""A phase's sub-states (dotted paths, ``docking.search.wall_follow``) -> their handlers."""


@dataclass(frozen=True, slots=True)
class PhaseLoop:
    """A phase whose task runs the handler of its current sub-state (``run_phase``).

    Data, so that a test can hold the handlers against the state table without running
    anything: a sub-state without a handler would idle until the phase's timeout.
    """

    phase: str
    handlers: Handlers

    async def run(self, ctx: RobotContext, senses: DockSenses) -> None:
        await run_phase(ctx, senses, self.phase, self.handlers)


async def run_phase(ctx: RobotContext, senses: DockSenses, phase: str,
                    handlers: Handlers) -> None:
    """Run a phase's sub-steps: the handler of whichever sub-state is current, until the
    machine leaves ``phase`` (this task is cancelled then). A handler ends by firing the
    trigger to the next sub-state; one that does not is run again after a short wait.

    A handler whose sub-state was left by another trigger (a sub-state's own timeout, such
    as ``wait_empty``'s) is cancelled at once: it must not go on acting for a state the
    robot is no longer in (the station's suction ran on after ``vacuum_off``)."""
    while ctx.state.startswith(phase + "."):
        before = ctx.state
        handler = handlers.get(before)
        if handler is None:
            await asyncio.sleep(IDLE_S)
            continue
        await _run_while_in(ctx, before, handler, senses)
        if ctx.state == before:
            await asyncio.sleep(IDLE_S)


async def _run_while_in(ctx: RobotContext, state: str, handler: PhaseStep,
                        senses: DockSenses) -> None:
    """Run ``handler`` while the machine stays in ``state``; cancel it once it has left (the
    handler's own trigger has moved the machine on by the time it returns, so only a
    handler overtaken by another trigger is cut short)."""

    async def step() -> None:
        await handler(ctx, senses)

    task = asyncio.create_task(step(), name=f"dock-step:{state}")
    try:
        while True:
            done, _ = await asyncio.wait({task}, timeout=IDLE_S)
            if done:
                task.result()
                return
            if ctx.state != state:
                log.info("dock.step_overtaken", step=state, state=ctx.state)
                await cancel_and_wait(task)
                return
    finally:
        if not task.done():
            await cancel_and_wait(task)
