"""MCU endpoints the serial-link conformance suite runs against, and how to add one.

An endpoint is one motor board implementation reachable through a ``SerialOpener``: the
FakeMcu over the in-memory byte pipe (virtual time), the FakeMcu on a real pseudo-terminal
(real time, pyserial in the path), and - added by the firmware work - the real firmware in
simavr. The suite talks to it ONLY through the real driver (``ArduinoLink``) or raw bytes from
``opener``, and reads back what the plant saw. To add an endpoint, implement ``McuEndpoint``
and register a factory in ``ENDPOINTS``; list in ``faults`` only what it can inject (tests
needing others are skipped for it).
"""

from __future__ import annotations

import asyncio
import contextlib
import tempfile
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import Any, Protocol

from simavr_endpoint import SimavrEndpoint

from bench import PlantBench, TimedPlant
from drivers.arduino import ArduinoLink
from drivers.serial_port import open_serial
from hal.ports import SerialOpener
from sim import vclock
from sim.devices.motor_board.fake_mcu import FakeMcu
from sim.devices.motor_board.pty_mcu import PtyMcu
from sim.devices.sim_serial import SimSerialPorts

FAULTS = frozenset({"corrupt", "unplug", "reset", "delay"})


class McuEndpoint(Protocol):
    """One MCU implementation under test.

    Times (``pwm_log``) are on the running event loop's clock, so a test can compare them
    with ``loop.time()``; ``timing_slack_s`` is how late the endpoint may see a timed event
    (the deadman) against the contract, e.g. scheduling jitter of a real-time emulator.
    """

    name: str
    virtual_time: bool  # True: scenarios run on sim.vclock's VirtualTimeLoop
    faults: frozenset[str]  # subset of FAULTS this endpoint can inject
    timing_slack_s: float
    opener: SerialOpener  # opens ``port`` as a raw stream pair (for byte-level tests)
    port: str

    async def start(self) -> None: ...
    async def close(self) -> None: ...

    def link(self, **config: Any) -> ArduinoLink:
        """A real driver on this endpoint, not started; ``config`` overrides LinkConfig."""

    def pwm_log(self) -> list[tuple[float, int, int, bool, bool]]:
        """Every PWM setting the plant received, in order: (t_s, left, right, l_fwd, r_fwd)."""

    def servo_log(self) -> list[int]: ...

    def executed(self) -> list[tuple[int | None, str]] | None:
        """(SEQ, payload) of every command the MCU executed, or None if it cannot tell."""

    def set_sensors(self, *, ticks: tuple[int, int] | None = None,
                    range_cm: float | None = None,
                    battery: tuple[float, float, bool] | None = None) -> None:
        """What the encoders, range sensor and battery (V, %, on dock) report from now on."""

    def set_dock_inputs(self, *, signal: tuple[int, int] | None = None,
                        contact_mv: int | None = None, bumpers: tuple[bool, bool] | None = None,
                        wall_cm: float | None = None, bin_pct: float | None = None) -> None:
        """What the docking sensors (IRS, DOCK, BUMP, WALL, BIN) report from now on."""

    def evac_log(self) -> list[bool]:
        """Each change of the board's EVAC output, in order."""

    def corrupt(self, pct: float) -> None: ...
    def unplug(self) -> None: ...
    def replug(self) -> None: ...
    def reset(self) -> None: ...
    def delay(self, seconds: float) -> None: ...



class _FakeMcuEndpoint(PlantBench):
    """What both FakeMcu endpoints share: the plant, the records and the fault switches."""

    name = "fake"
    virtual_time = True
    faults = FAULTS
    timing_slack_s = 0.0
    port = "/dev/ttyACM0"

    def __init__(self, seed: int = 7) -> None:
        self.plant = TimedPlant()
        self.mcu = FakeMcu(self.plant, seed=seed)
        self.dock = self.mcu
        self.opener: SerialOpener = SimSerialPorts()

    async def start(self) -> None: ...

    async def close(self) -> None:
        await self.mcu.close()

    def executed(self) -> list[tuple[int | None, str]] | None:
        return [(e.seq, e.payload) for e in self.mcu.executed]

class PipeEndpoint(_FakeMcuEndpoint):
    """The FakeMcu behind ``SimSerialPorts`` (byte pipe at the wire's baud), virtual time."""

    name = "fake-pipe"

    def __init__(self, seed: int = 7) -> None:
        super().__init__(seed)
        ports = SimSerialPorts()
        ports.attach(self.port, self.mcu)
        self.opener = ports


class PtyEndpoint(_FakeMcuEndpoint):
    """The FakeMcu on a pseudo-terminal, opened by pyserial; real time."""

    name = "fake-pty"
    virtual_time = False
    timing_slack_s = 0.1

    def __init__(self, seed: int = 7) -> None:
        super().__init__(seed)
        self._dir = tempfile.TemporaryDirectory(prefix="robotd-pty-")
        self.port = str(Path(self._dir.name) / "ttyFAKE")
        self.server = PtyMcu(self.mcu, link=self.port)
        self.opener = open_serial

    async def start(self) -> None:
        await self.server.start()

    async def close(self) -> None:
        await self.server.close()
        with contextlib.suppress(OSError):
            self._dir.cleanup()


ENDPOINTS: dict[str, Callable[[], McuEndpoint]] = {
    "fake-pipe": PipeEndpoint,
    "fake-pty": PtyEndpoint,
    "simavr": SimavrEndpoint,  # the real firmware in an emulated ATmega328P (firmware/)
}

Scenario = Callable[[McuEndpoint], Awaitable[None]]


def run_scenario(make: Callable[[], McuEndpoint], scenario: Scenario) -> None:
    """Build an endpoint (its constructor needs no loop), start it, run ``scenario`` on the
    kind of loop it needs, close it."""
    endpoint = make()

    async def main() -> None:
        await endpoint.start()
        try:
            await scenario(endpoint)
        finally:
            await endpoint.close()

    if endpoint.virtual_time:
        vclock.run(main())
    else:
        asyncio.run(main())
