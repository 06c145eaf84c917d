"""The real firmware on an emulated ATmega328P (simavr) as a conformance-suite MCU endpoint.

The driver opens the harness's pseudo-terminal with pyserial like a real board; what the
wheels and servo do is read from the emulated pins through ``SimavrBridge``. Real time only
(the emulator runs in wall time). Skipped, with the reason, without the AVR toolchain/simavr.
"""

from __future__ import annotations

import asyncio
import contextlib
from dataclasses import dataclass, field, replace
from typing import Any

import pytest

from drivers.arduino import ArduinoLink, LinkConfig
from drivers.serial_port import open_serial
from hal.ports import SerialOpener
from hal.sim.plant import RecordingPlant
from hal.sim.simavr_mcu import SimavrBridge, SimavrMcu, missing_toolchain


@dataclass
class _StampedPlant(RecordingPlant):
    """A RecordingPlant that stamps each PWM setting with the loop time."""

    timed_pwm: list[tuple[float, int, int, bool, bool]] = field(default_factory=list)

    def apply_pwm(self, left_pwm: int, right_pwm: int, left_forward: bool,
                  right_forward: bool) -> None:
        super().apply_pwm(left_pwm, right_pwm, left_forward, right_forward)
        t_s = asyncio.get_running_loop().time()
        self.timed_pwm.append((t_s, left_pwm, right_pwm, left_forward, right_forward))


class SimavrEndpoint:
    """firmware/robotd_mcu on simavr, UART on a pty, pins read back through the harness."""

    name = "simavr"
    virtual_time = False
    faults = frozenset({"corrupt", "unplug", "reset", "delay"})
    timing_slack_s = 0.15  # pin samples cross a pipe; the emulator may lag a loaded machine

    def __init__(self) -> None:
        reason = missing_toolchain()
        if reason is not None:
            pytest.skip(reason)
        self.plant = _StampedPlant()
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
        bridge = SimavrBridge(self._mcu, self.plant)
        self._feed = asyncio.get_running_loop().create_task(bridge.run())

    async def close(self) -> None:
        if self._feed is not None:
            self._feed.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._feed
        if self._mcu is not None:
            await self._mcu.close()

    def link(self, **config: Any) -> ArduinoLink:
        return ArduinoLink(self.opener, replace(LinkConfig(port=self.port), **config))

    def pwm_log(self) -> list[tuple[float, int, int, bool, bool]]:
        return list(self.plant.timed_pwm)

    def servo_log(self) -> list[int]:
        return list(self.plant.servo_angles)

    def executed(self) -> list[tuple[int | None, str]] | None:
        return None  # the firmware keeps no log; the pins tell what it did

    def set_sensors(self, *, ticks: tuple[int, int] | None = None,
                    range_cm: float | None = None,
                    battery: tuple[float, float, bool] | None = None) -> None:
        if ticks is not None:
            self.plant.ticks = ticks
        if range_cm is not None:
            self.plant.range_cm = range_cm
        if battery is not None:
            self.plant.voltage_v, self.plant.charge_pct, self.plant.on_dock = battery

    def corrupt(self, pct: float) -> None:
        self.mcu.corrupt(pct)

    def unplug(self) -> None:
        self.mcu.unplug()

    def replug(self) -> None:
        self.mcu.replug()

    def reset(self) -> None:
        self.mcu.reset()

    def delay(self, seconds: float) -> None:
        self.mcu.delay(seconds)
