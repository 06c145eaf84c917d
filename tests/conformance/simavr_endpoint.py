"""The real firmware on an emulated ATmega328P (simavr) as a conformance-suite MCU endpoint.

The driver opens the harness's pseudo-terminal with pyserial like a real board; what the
wheels and servo do is read from the emulated pins through ``SimavrBridge``. Real time only
(the emulator runs in wall time). Skipped, with the reason, without the AVR toolchain/simavr.
"""

from __future__ import annotations

import asyncio
import contextlib

import pytest

from bench import PlantBench, TimedPlant
from drivers.serial_port import open_serial
from hal.ports import SerialOpener
from sim.devices.motor_board.dock_inputs import DockInputs
from sim.devices.motor_board.simavr_bridge import SimavrBridge
from sim.devices.motor_board.simavr_mcu import SimavrMcu, missing_toolchain


class SimavrEndpoint(PlantBench):
    """firmware/robotd_mcu on simavr, UART on a pty, pins read back through the harness."""

    name = "simavr"
    virtual_time = False
    faults = frozenset({"corrupt", "unplug", "reset", "delay"})
    timing_slack_s = 0.15  # pin samples cross a pipe; the emulator may lag a loaded machine

    def __init__(self) -> None:
        reason = missing_toolchain()
        if reason is not None:
            pytest.skip(reason)
        self.plant = TimedPlant()
        self.dock = DockInputs()
        self.opener: SerialOpener = open_serial
        self.port = ""
        self._mcu: SimavrMcu | None = None
        self._feed: asyncio.Task[None] | None = None

    @property
    def mcu(self) -> SimavrMcu:
        assert self._mcu is not None, "start() first"
        return self._mcu

    async def start(self) -> None:
        self._mcu = await SimavrMcu.start()
        self.port = self._mcu.uart_path
        bridge = SimavrBridge(self._mcu, self.plant, dock=self.dock)
        self._feed = asyncio.get_running_loop().create_task(bridge.run())

    async def close(self) -> None:
        if self._feed is not None:
            self._feed.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._feed
        if self._mcu is not None:
            await self._mcu.close()

    def executed(self) -> list[tuple[int | None, str]] | None:
        return None  # the firmware keeps no log; the pins tell what it did
