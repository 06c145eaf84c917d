"""What a behaviour receives: the devices, the settings, the state store, triggers and events."""

from __future__ import annotations

import asyncio
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

from behaviours.machine_tables import CoreTrigger, RootState
from behaviours.persistence import EStopLatch, KeyValueStore, MissionRecord, Persisted
from hal.backend import Devices
from hal.ports import WallClock
from hal.telemetry import NULL_TELEMETRY, Telemetry

if TYPE_CHECKING:
    from hal.settings import SettingsView

__all__ = ["EventSink", "Fault", "KeyValueStore", "MachineHandle", "RobotContext"]

FAULT_STATES = (RootState.RECOVERY,)
"""Where a robot stands because of a fault (a fault reported elsewhere is over)."""


@dataclass(frozen=True, slots=True)
class Fault:
    """Why the robot went to ``recovery``: a short code (``line_lost``) and a sentence."""

    code: str
    message: str


@runtime_checkable
class MachineHandle(Protocol):
    """The part of the state machine a behaviour may use."""

    @property
    def state(self) -> str: ...
    async def trigger(self, name: str, **kwargs: Any) -> bool: ...


class EventSink(Protocol):
    def __call__(self, kind: str, /, **fields: Any) -> None: ...


class RobotContext:
    """Everything a behaviour may touch; nothing else is passed to behaviours.

    Args:
        devices: the robot's devices (a slot is None when the robot has no such device).
        settings: the running config (``settings.get("line_follow.kp")``, ``watch``).
        store: crash-safe key/value store for mission state.
        wall_clock: the one source of wall-clock timestamps.
        emit: records an event (``emit("beacon.arrived", room="A")``).
        telemetry: what behaviours show the live view (``hal.telemetry``; a no-op when off).
        state_dir: the daemon's state directory.
    """

    def __init__(self, devices: Devices, settings: SettingsView, store: KeyValueStore,
                 wall_clock: WallClock, emit: EventSink, *,
                 telemetry: Telemetry = NULL_TELEMETRY, state_dir: Path | None = None) -> None:
        self.devices = devices
        self.state_dir = state_dir
        """The daemon's state directory (where a profile keeps files it makes: maps), or
        None when it has none."""
        self.settings = settings
        self.store = store
        self.wall_clock = wall_clock
        self._emit = emit
        self.telemetry = telemetry
        self._machine: MachineHandle | None = None
        self.estop_latch = EStopLatch(store, wall_clock)
        self._persisted: dict[str, Persisted] = {}
        self._fault: Fault | None = None

    def attach(self, machine: MachineHandle) -> None:
        """Called once by the state machine that this context drives."""
        self._machine = machine

    @property
    def state(self) -> str:
        """The dotted state path, e.g. ``docking.approach``."""
        return self._machine.state if self._machine is not None else "boot"

    async def trigger(self, name: str, **kwargs: Any) -> bool:
        """Fire a machine trigger; False (not an exception) when the current state refuses it.

        ``fault`` takes ``code`` and ``reason``: what ``fault`` then shows while the robot is
        in recovery."""
        if self._machine is None:
            return False
        if name == CoreTrigger.FAULT:
            self.note_fault(str(kwargs.get("code") or "fault"), str(kwargs.get("reason") or ""))
        return await self._machine.trigger(name, **kwargs)

    def note_fault(self, code: str, message: str) -> None:
        """Remember why the robot is about to go to recovery (``fault`` shows it there)."""
        self._fault = Fault(code, message)

    @property
    def fault(self) -> Fault | None:
        """The fault that keeps the robot in recovery, or None (not in recovery)."""
        state = self.state
        if self._fault is None or not any(state == s or state.startswith(s + ".")
                                          for s in FAULT_STATES):
            return None
        return self._fault

    def persisted(self, record: MissionRecord) -> Persisted:
        """The live values of ``record``, restored from the store the first time it is asked
        for (the daemon asks for every record of ``profile.mission_records()`` in ``boot``)."""
        held = self._persisted.get(record.key)
        if held is None:
            held = self._persisted[record.key] = Persisted(self.store, record)
            if held.restored:
                self.emit("persist.restored", key=record.key, values=held.values())
        elif held.record != record:
            msg = f"{record.key}: declared twice, differently"
            raise ValueError(msg)
        return held

    def emit(self, kind: str, **fields: Any) -> None:
        """Record an event: it goes to the event log, ``robotctl events`` and subscribers."""
        self._emit(kind, **fields)

    @staticmethod
    def loop_time_s() -> float:
        """The event loop's clock (virtual in the simulator)."""
        return asyncio.get_running_loop().time()
