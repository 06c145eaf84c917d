"""A motor board whose encoder counters stop updating (the seed's "encoder failure").

``FreezableEncoders`` stands between a ``FakeMcu`` and its plant: motors, servo, range sensor
and battery pass through; ``encoder_ticks`` reports the counts of the moment ``freeze`` was
called for as long as the fault lasts (a loose encoder cable: the wheels still turn in the
world, the board's counters do not). After ``restore`` the counters run on from where they
stood: the ticks missed meanwhile are lost, as on the bench.
"""

from __future__ import annotations

from sim.world.plant import MotorPlant


class FreezableEncoders:
    """A ``MotorPlant`` whose encoder counts can be frozen."""

    def __init__(self, plant: MotorPlant) -> None:
        self.plant = plant
        self.frozen: tuple[int, int] | None = None
        self.lost = (0, 0)  # ticks missed while frozen, over every fault so far
        self.freezes = 0

    def freeze(self) -> None:
        if self.frozen is None:
            self.frozen = self.encoder_ticks()
            self.freezes += 1

    def restore(self) -> None:
        if self.frozen is None:
            return
        left, right = self.plant.encoder_ticks()
        self.lost = (left - self.frozen[0], right - self.frozen[1])
        self.frozen = None

    # MotorPlant ---------------------------------------------------------------------------
    def encoder_ticks(self) -> tuple[int, int]:
        if self.frozen is not None:
            return self.frozen
        left, right = self.plant.encoder_ticks()
        return (left - self.lost[0], right - self.lost[1])

    def apply_pwm(self, left_pwm: int, right_pwm: int, left_forward: bool,
                  right_forward: bool) -> None:
        self.plant.apply_pwm(left_pwm, right_pwm, left_forward, right_forward)

    def front_range_cm(self) -> float:
        return self.plant.front_range_cm()

    def battery(self) -> tuple[float, float, bool]:
        return self.plant.battery()

    def servo(self, angle_deg: int) -> None:
        self.plant.servo(angle_deg)


def freezable(board_plant: MotorPlant) -> FreezableEncoders:
    """The board's plant as a ``FreezableEncoders`` (itself when it already is one)."""
    if isinstance(board_plant, FreezableEncoders):
        return board_plant
    return FreezableEncoders(board_plant)
