"""Doubles for docking's unit tests: a context whose machine records triggers, wheels that move
odometry, a dock IR device and motor-board senses whose readings the test sets."""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from typing import Any

from behaviours.context import RobotContext
from behaviours.docking.senses import DockSenses
from behaviours.motion.moves import Mover
from behaviours.motion.odometry import Odometry
from hal.backend import Devices
from hal.ports import system_wall_clock
from hal.readings import (
    BatteryReading,
    BinLevel,
    Bumpers,
    DockContacts,
    DockIrReading,
    DockSignal,
    LinkStats,
    MotorCommand,
)
from robotd.config import Settings
from robotd.config.loader import defaults

MAX_SPEED_MPS = 0.6
DEADBAND_PWM = 20


class DictStore(dict[str, Any]):
    def put(self, key: str, value: Any) -> None:
        self[key] = value

    def delete(self, key: str) -> None:
        self.pop(key, None)

    async def flush(self) -> None:
        return None


class Recorder:
    """The machine as a behaviour sees it: records triggers; ``moves`` maps a trigger to the
    state it leads to (else the state stays)."""

    def __init__(self, state: str, moves: dict[str, str] | None = None) -> None:
        self.state = state
        self.moves = moves or {}
        self.fired: list[tuple[str, dict[str, Any]]] = []

    async def trigger(self, name: str, **kwargs: Any) -> bool:
        self.fired.append((name, kwargs))
        self.state = self.moves.get(name, self.state)
        return True

    @property
    def names(self) -> list[str]:
        return [n for n, _ in self.fired]


class Feed:
    """A sensor whose ``latest()`` the test sets."""

    def __init__(self, value: Any = None) -> None:
        self.value = value

    def latest(self) -> Any:
        return self.value

    async def next_reading(self) -> Any:
        await asyncio.sleep(0.05)
        return self.value


class FakeDockIr(Feed):
    """The dock IR device: what each receiver sees (``see``), stamped now; ``lost()``."""

    name = "dock_ir"

    def __init__(self) -> None:
        super().__init__(DockIrReading())
        self.running = True
        self.frozen = False
        self.line_errors = 0

    def see(self, **beams: tuple[str, ...]) -> None:
        self.value = DockIrReading(beams={r: frozenset(b) for r, b in beams.items()})

    def latest(self) -> DockIrReading:
        if not self.frozen:
            self.value = DockIrReading(beams=self.value.beams, t_s=_now())
        return self.value  # type: ignore[no-any-return]

    def lost(self) -> None:
        self.frozen = True

    async def start(self) -> None: ...
    async def close(self) -> None: ...

    def status(self) -> dict[str, Any]:
        return {"running": self.running, "line_errors": self.line_errors}


class Wheels:
    """Motors whose commands move an odometry pose (no slip): the lowest layer of a move."""

    name = "wheels"
    connected = True

    def __init__(self, odometry: Odometry) -> None:
        self.odometry = odometry
        self.commands: list[MotorCommand] = []
        self.stops = 0
        self._speeds = (0.0, 0.0)
        self._task: asyncio.Task[None] | None = None

    def start_plant(self) -> None:
        self._task = asyncio.create_task(self._plant())

    async def _plant(self) -> None:
        while True:
            await asyncio.sleep(0.01)
            left, right = self._speeds
            self.odometry.integrate(left * 0.01, right * 0.01)

    async def drive(self, command: MotorCommand) -> None:
        self.commands.append(command)
        self._speeds = (_mps(command.left_pwm, command.left_forward),
                        _mps(command.right_pwm, command.right_forward))

    async def stop(self) -> None:
        self.stops += 1
        self._speeds = (0.0, 0.0)

    async def start(self) -> None: ...
    async def close(self) -> None: ...

    def status(self) -> dict[str, Any]:
        return {}

    def on_link_change(self, callback: Callable[[bool], None]) -> None: ...

    def link_stats(self) -> LinkStats:
        return LinkStats(connected=True)


def _mps(pwm: int, forward: bool) -> float:
    if pwm <= DEADBAND_PWM:
        return 0.0
    speed = (pwm - DEADBAND_PWM) / (255 - DEADBAND_PWM) * MAX_SPEED_MPS
    return speed if forward else -speed


def _now() -> float:
    return asyncio.get_running_loop().time()


class Rig:
    """A robot's docking devices as doubles, a context and its recorded machine."""

    def __init__(self, state: str, moves: dict[str, str] | None = None) -> None:
        self.settings = Settings(defaults())
        self.odometry = Odometry(0.30, 0.035, 360)
        self.wheels = Wheels(self.odometry)
        self.ir = FakeDockIr()
        self.signal = Feed(DockSignal(300, 300, 0.0))
        self.contacts = Feed(DockContacts(0, 0.0))
        self.bumpers = Feed(Bumpers(False, False, 0.0))
        self.bin = Feed(BinLevel(0.0, 0.0))
        self.battery = Feed(BatteryReading(12.0, 50.0, False, False, 0.0))
        self.events: list[tuple[str, dict[str, Any]]] = []
        self.store = DictStore()
        devices = Devices(motors=self.wheels, dock_ir=self.ir, dock_signal=self.signal,
                          dock_contacts=self.contacts, bumpers=self.bumpers, bin=self.bin,
                          battery=self.battery)  # type: ignore[arg-type]
        self.ctx = RobotContext(devices, self.settings, self.store, system_wall_clock,
                                lambda kind, **f: self.events.append((kind, f)))
        self.machine = Recorder(state, moves)
        self.ctx.attach(self.machine)

    def senses(self) -> DockSenses:
        return DockSenses.from_ctx(self.ctx, self.odometry)

    def mover(self) -> Mover:
        return Mover(self.wheels, self.odometry, self.settings)
