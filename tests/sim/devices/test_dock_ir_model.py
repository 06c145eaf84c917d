"""The simulated dock IR receivers: the dock's beams at a pose, decoded by the real driver."""

from __future__ import annotations

import asyncio
import math
import random
from typing import Any

import pytest

from drivers.dock_ir.oi_codes import CodeTable
from drivers.dock_ir.receivers import DockIrReceivers
from hal.readings import DockIrReading
from sim import vclock
from sim.devices.dock_ir_model import MOUNTS, SimDockIr, dock_signal
from sim.world.body import DiffDriveBody
from sim.world.floor_plan import World
from sim.world.geometry import Pose

RECEIVERS = tuple(m.name for m in MOUNTS)
DOCK_CODES = {"force_field": 161, "front_left": 168, "front_right": 164, "far_left": 184,
              "far_right": 180, "centre": 176}
"""The dock's default codes as a robot's ``docking.ir_codes`` would name them."""
TABLE = CodeTable.build(DOCK_CODES, ("force_field", "front_left", "front_right"))
DOCK_X, DOCK_Y = 0.14, 2.0  # on the west wall's middle, looking east


def _world(**extra: Any) -> World:
    return World.from_table({"width_m": 6, "height_m": 4,
                             "dock": {"x_m": DOCK_X, "y_m": DOCK_Y, "heading_deg": 0},
                             **extra})


def _facing_dock(distance_m: float, bearing_deg: float) -> Pose:
    """A robot ``distance_m`` out from the dock at ``bearing_deg`` off its axis (+: the dock's
    left), looking at the dock."""
    b = math.radians(bearing_deg)
    x, y = DOCK_X + distance_m * math.cos(b), DOCK_Y + distance_m * math.sin(b)
    return Pose(x, y, math.atan2(DOCK_Y - y, DOCK_X - x))


def _read(world: World, pose: Pose, seconds: float = 1.0, **model: Any
          ) -> tuple[list[DockIrReading], SimDockIr, DockIrReceivers]:
    """Run the real driver on the simulated receivers; the readings of the last 0.4 s."""

    async def main() -> tuple[list[DockIrReading], SimDockIr, DockIrReceivers]:
        loop = asyncio.get_running_loop()
        body = DiffDriveBody(world, pose, clock=loop.time)
        source = SimDockIr(body, rng=random.Random(7), **model)
        device = DockIrReceivers(lambda: source, receivers=RECEIVERS, table=TABLE)
        await device.start()
        readings: list[DockIrReading] = []
        try:
            while loop.time() < seconds:
                reading = await device.next_reading()
                if reading.t_s >= seconds - 0.4:
                    readings.append(reading)
        finally:
            await device.close()
        return readings, source, device

    result: tuple[list[DockIrReading], SimDockIr, DockIrReceivers] = vclock.run(main())
    return result


def _all_beams(reading: DockIrReading) -> set[str]:
    return {b for beams in reading.beams.values() for b in beams}


class TestBeamsThroughTheDriver:
    def test_on_the_axis_both_front_beams_and_the_centre(self) -> None:
        """0.8 m out on the axis, facing the dock: front_left, front_right and centre, in
        every reading (the 144 ms cycle fits the 0.2 s window)."""
        readings, _, device = _read(_world(), _facing_dock(0.8, 0))
        for reading in readings:
            assert reading.sees("front_left", "front_left")
            assert reading.sees("front_right", "front_right")
            assert reading.sees("omni", "centre")
            assert _all_beams(reading) == {"front_left", "front_right", "centre"}
        assert device.status()["total"]["codes"] > 0

    def test_in_the_overlap_the_buoys_or_into_172(self) -> None:
        """Where both front beams reach, the omni receiver reads the OI's red + green code."""
        readings, _, _ = _read(_world(), _facing_dock(1.5, 0))
        assert 172 in readings[-1].codes["omni"]
        assert 168 not in readings[-1].codes["omni"]

    def test_inside_the_force_field_it_combines_too(self) -> None:
        readings, _, _ = _read(_world(), _facing_dock(0.45, 0))
        assert 173 in readings[-1].codes["omni"]  # force field + red + green

    def test_off_to_the_left_far_left_only(self) -> None:
        readings, _, _ = _read(_world(), _facing_dock(2.0, -45))
        for reading in readings:
            assert _all_beams(reading) == {"far_left"}

    def test_off_to_the_right_far_right_only(self) -> None:
        readings, _, _ = _read(_world(), _facing_dock(2.0, 45))
        assert _all_beams(readings[-1]) == {"far_right"}

    def test_behind_a_wall_nothing(self) -> None:
        world = _world(walls=[{"x1": 1.2, "y1": 0.5, "x2": 1.2, "y2": 3.5}])
        readings, source, device = _read(world, _facing_dock(2.0, 0))
        assert all(_all_beams(r) == set() for r in readings)
        assert source.edges == 0
        assert device.status()["total"]["codes"] == 0

    def test_a_person_in_the_beam_blocks_it(self) -> None:
        world = _world(people=[{"x_m": 1.1, "y_m": DOCK_Y}])
        readings, _, _ = _read(world, _facing_dock(2.0, 0))
        assert _all_beams(readings[-1]) == set()

    def test_facing_away_only_the_rear_and_omni_receivers_see_it(self) -> None:
        pose = _facing_dock(0.8, 0)
        away = Pose(pose.x_m, pose.y_m, pose.heading_rad + math.pi)
        readings, _, _ = _read(_world(), away)
        seeing = {r for r, beams in readings[-1].beams.items() if beams}
        assert seeing == {"rear", "omni"}

    def test_beams_off_nothing(self) -> None:
        world = _world()
        assert world.dock is not None
        world.dock.emitting = False
        readings, _, _ = _read(world, _facing_dock(0.8, 0))
        assert _all_beams(readings[-1]) == set()


class TestDamage:
    def test_lost_edges_are_counted_and_never_read_as_another_beam(self) -> None:
        readings, _, device = _read(_world(), _facing_dock(0.8, 0), seconds=3.0,
                                    jitter_us=150, drop_fraction=0.02)
        total = device.status()["total"]
        assert total["dropped_edges"] + total["recovered_edges"] > 0
        assert total["unknown_codes"] == 0
        for reading in readings:
            assert _all_beams(reading) <= {"front_left", "front_right", "centre"}

    def test_noise_spikes_are_counted_as_glitches(self) -> None:
        _, _, device = _read(_world(), _facing_dock(2.0, -45), seconds=2.0, spikes_per_s=20)
        assert device.status()["total"]["glitches"] > 0


class TestBatches:
    def test_one_batch_per_slot_never_one_per_edge(self) -> None:
        """A second in a beam: at most one wake-up and batch per 36 ms slot."""
        _, source, _ = _read(_world(), _facing_dock(0.8, 0), seconds=1.0)
        assert source.edges > 10 * source.batches
        assert source.batches <= math.ceil(1.0 / 0.036) + 1


class TestStrength:
    def test_facing_the_dock_on_its_axis_the_two_are_equal(self) -> None:
        body = DiffDriveBody(_world(), _facing_dock(0.8, 0))
        left, right = dock_signal(body)
        assert left == right > 0

    @pytest.mark.parametrize("turn_deg", [8, -8])
    def test_the_dock_to_the_right_makes_left_stronger(self, turn_deg: float) -> None:
        """Turned left (+), the dock lies to the right: the crossed front_left reads more."""
        pose = _facing_dock(0.8, 0)
        body = DiffDriveBody(_world(), Pose(pose.x_m, pose.y_m,
                                            pose.heading_rad + math.radians(turn_deg)))
        left, right = dock_signal(body)
        assert (left > right) == (turn_deg > 0)

    def test_closer_is_stronger_and_it_saturates_at_10_bits(self) -> None:
        far = dock_signal(DiffDriveBody(_world(), _facing_dock(2.0, 0)))
        near = dock_signal(DiffDriveBody(_world(), _facing_dock(0.3, 0)))
        assert far[0] < near[0] <= 1023

    def test_no_dock_no_signal(self) -> None:
        body = DiffDriveBody(World.from_table({"width_m": 3, "height_m": 3}), Pose(1, 1, 0))
        assert dock_signal(body) == (0, 0)
