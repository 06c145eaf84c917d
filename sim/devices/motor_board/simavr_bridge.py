"""Couples the real firmware in simavr to a simulated body.

The emulated PWM pins drive a ``MotorPlant``; the plant's wheel motion goes back as encoder
edges, and its range, battery and dock contacts as the board's analog and digital inputs.
The docking sensors come from a ``DockInputs`` (the fake MCU's sources, which the world
feeds), and the EVAC pin is recorded there, so a world sees either board the same way.
"""

from __future__ import annotations

import asyncio

from sim.devices.motor_board.dock_inputs import DockInputs, read_source
from sim.devices.motor_board.simavr_mcu import McuPins, SimavrMcu
from sim.world.plant import MotorPlant


class SimavrBridge:
    """Couples the emulated board to a simulated body (``MotorPlant``).

    Pin changes reach the plant as soon as the harness reports them; the plant's encoders,
    range and battery are fed back every ``period_s``. The MCU's encoder counts start at 0
    at boot, so the plant's full count is injected first.
    """

    def __init__(self, mcu: SimavrMcu, plant: MotorPlant, period_s: float = 0.01,
                 dock: DockInputs | None = None) -> None:
        self.mcu = mcu
        self.plant = plant
        self.dock = dock
        self._dock_sent: dict[str, object] = {}
        self.period_s = period_s
        self._ticks = (0, 0)
        self._drive: tuple[int, int, bool, bool] | None = None
        self._servo_deg: int | None = None
        self._range_cm: float | None = None
        self._battery: tuple[float, bool] | None = None
        mcu.add_listener(self._on_pins)
        if mcu.pins is not None:
            self._on_pins(mcu.pins)

    def _on_pins(self, pins: McuPins) -> None:
        if pins.drive != self._drive:
            self._drive = pins.drive
            self.plant.apply_pwm(*pins.drive)
        if pins.servo_deg is not None and pins.servo_deg != self._servo_deg:
            self._servo_deg = pins.servo_deg
            self.plant.servo(pins.servo_deg)
        if self.dock is not None and bool(pins.evac) != self.dock.evac:
            self.dock.record_evac(bool(pins.evac), asyncio.get_running_loop().time())

    async def step(self) -> None:
        """Feeds the plant's encoders, range and battery to the MCU's inputs."""
        ticks = self.plant.encoder_ticks()
        delta = (ticks[0] - self._ticks[0], ticks[1] - self._ticks[1])
        if delta != (0, 0):
            self._ticks = ticks
            await self.mcu.inject_encoder(*delta)
        range_cm = round(self.plant.front_range_cm())
        if range_cm != self._range_cm:
            self._range_cm = range_cm
            await self.mcu.set_range_cm(range_cm)
        voltage_v, _pct, on_dock = self.plant.battery()
        battery = (round(voltage_v, 2), on_dock)
        if battery != self._battery:
            if self._battery is None or battery[1] != self._battery[1]:
                await self.mcu.set_dock(on_dock)
            self._battery = battery
            await self.mcu.set_battery_v(voltage_v)
        if self.dock is not None:
            await self._step_dock(self.dock)

    async def _step_dock(self, dock: DockInputs) -> None:
        """Injects each docking input the world gives that changed since the last step."""
        signal = read_source(dock.dock_signal)
        if signal is not None and self._changed("signal", signal):
            await self.mcu.set_dock_signal(round(signal[0]), round(signal[1]))
        contact_mv = read_source(dock.contact_mv)
        if contact_mv is not None and self._changed("contact", contact_mv):
            await self.mcu.set_contact_mv(round(contact_mv))
        bumpers = read_source(dock.bumpers)
        if bumpers is not None and self._changed("bumpers", bumpers):
            await self.mcu.set_bumpers(bool(bumpers[0]), bool(bumpers[1]))
        wall_cm = read_source(dock.wall_cm)
        if wall_cm is not None and self._changed("wall", wall_cm):
            await self.mcu.set_wall_cm(wall_cm)
        bin_pct = read_source(dock.bin_pct)
        if bin_pct is not None and self._changed("bin", bin_pct):
            await self.mcu.set_bin_pct(bin_pct)

    def _changed(self, name: str, value: object) -> bool:
        if self._dock_sent.get(name) == value:
            return False
        self._dock_sent[name] = value
        return True

    async def run(self) -> None:
        """Feeds the sensors every ``period_s`` of loop time until cancelled."""
        loop = asyncio.get_running_loop()
        next_t = loop.time()
        while True:
            await self.step()
            next_t += self.period_s
            await asyncio.sleep(max(0.0, next_t - loop.time()))
