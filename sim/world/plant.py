"""What the simulated motor board drives and reads: the body's wheels, encoders and sensors.

The fake MCU (and the simavr bridge) talk to a ``MotorPlant``; the simulated body implements
it. Keeping this narrow lets protocol tests use a tiny recording plant.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable


@runtime_checkable
class MotorPlant(Protocol):
    def apply_pwm(self, left_pwm: int, right_pwm: int, left_forward: bool,
                  right_forward: bool) -> None:
        """Set the H-bridge outputs: duty 0-255 and direction per wheel."""

    def encoder_ticks(self) -> tuple[int, int]:
        """Cumulative signed encoder ticks (left, right)."""

    def front_range_cm(self) -> float:
        """What the front distance sensor measures now."""

    def battery(self) -> tuple[float, float, bool]:
        """(voltage V, charge %, on the dock's charging contacts)."""

    def servo(self, angle_deg: int) -> None:
        """Move the box servo."""


@dataclass
class RecordingPlant:
    """A plant that records what it was told; encoders count PWM applied (for protocol tests)."""

    pwm: list[tuple[int, int, bool, bool]] = field(default_factory=list)
    servo_angles: list[int] = field(default_factory=list)
    ticks: tuple[int, int] = (0, 0)
    range_cm: float = 100.0
    voltage_v: float = 12.3
    charge_pct: float = 80.0
    on_dock: bool = False

    def apply_pwm(self, left_pwm: int, right_pwm: int, left_forward: bool,
                  right_forward: bool) -> None:
        self.pwm.append((left_pwm, right_pwm, left_forward, right_forward))

    def encoder_ticks(self) -> tuple[int, int]:
        return self.ticks

    def front_range_cm(self) -> float:
        return self.range_cm

    def battery(self) -> tuple[float, float, bool]:
        return self.voltage_v, self.charge_pct, self.on_dock

    def servo(self, angle_deg: int) -> None:
        self.servo_angles.append(angle_deg)

    @property
    def last_pwm(self) -> tuple[int, int, bool, bool] | None:
        return self.pwm[-1] if self.pwm else None
