"""What every conformance endpoint shares: a recording plant and the board's fault switches."""

from __future__ import annotations

import asyncio
from dataclasses import dataclass, field, replace
from typing import Any

from drivers.arduino import ArduinoLink, LinkConfig
from hal.ports import SerialOpener
from sim.devices.motor_board.dock_inputs import DockInputs
from sim.world.plant import RecordingPlant


@dataclass
class TimedPlant(RecordingPlant):
    """A RecordingPlant that also stamps each PWM setting with the loop time."""

    timed_pwm: list[tuple[float, int, int, bool, bool]] = field(default_factory=list)

    def apply_pwm(self, left_pwm: int, right_pwm: int, left_forward: bool,
                  right_forward: bool) -> None:
        super().apply_pwm(left_pwm, right_pwm, left_forward, right_forward)
        t_s = asyncio.get_running_loop().time()
        self.timed_pwm.append((t_s, left_pwm, right_pwm, left_forward, right_forward))


class PlantBench:
    """A board on a bench: a TimedPlant for its outputs and inputs; ``mcu`` has the switches.

    Subclasses set ``plant``, ``opener``, ``port``, ``dock`` (the docking sensors' sources and
    the EVAC record) and provide ``mcu`` (anything with ``corrupt``, ``unplug``, ``replug``,
    ``reset`` and ``delay``).
    """

    plant: TimedPlant
    dock: DockInputs
    opener: SerialOpener
    port: str
    mcu: Any

    def link(self, **config: Any) -> ArduinoLink:
        return ArduinoLink(self.opener, replace(LinkConfig(port=self.port), **config))

    def pwm_log(self) -> list[tuple[float, int, int, bool, bool]]:
        return list(self.plant.timed_pwm)

    def servo_log(self) -> list[int]:
        return list(self.plant.servo_angles)

    def set_sensors(self, *, ticks: tuple[int, int] | None = None,
                    range_cm: float | None = None,
                    battery: tuple[float, float, bool] | None = None) -> None:
        if ticks is not None:
            self.plant.ticks = ticks
        if range_cm is not None:
            self.plant.range_cm = range_cm
        if battery is not None:
            self.plant.voltage_v, self.plant.charge_pct, self.plant.on_dock = battery

    def set_dock_inputs(self, *, signal: tuple[int, int] | None = None,
                        contact_mv: int | None = None, bumpers: tuple[bool, bool] | None = None,
                        wall_cm: float | None = None, bin_pct: float | None = None) -> None:
        """What the docking sensors measure from now on (None: leave as it is)."""
        dock = self.dock
        dock.dock_signal = signal if signal is not None else dock.dock_signal
        dock.contact_mv = contact_mv if contact_mv is not None else dock.contact_mv
        dock.bumpers = bumpers if bumpers is not None else dock.bumpers
        dock.wall_cm = wall_cm if wall_cm is not None else dock.wall_cm
        dock.bin_pct = bin_pct if bin_pct is not None else dock.bin_pct

    def evac_log(self) -> list[bool]:
        """Each change of the EVAC output, in order."""
        return [on for _t, on in self.dock.evac_log]

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
