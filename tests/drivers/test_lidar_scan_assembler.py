"""Packets -> scans: cut at the angle wrap, clockwise sensor angles -> the robot's frame."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest

from drivers.lidar.config import LidarConfig
from drivers.lidar.packet import PACKET_DTYPE, Packet
from drivers.lidar.parser import Records
from drivers.lidar.scan_assembler import ScanAssembler
from hal.readings import LidarScan

STEP_CDEG = 80


def packets(count: int, distance_mm: Callable[[float], int], *, first: int = 0,
            skip: frozenset[int] = frozenset()) -> Records:
    """``count`` packets of a 10 Hz LD19 whose distance depends on the clockwise angle."""
    wire = b""
    for i in range(first, first + count):
        if i in skip:
            continue
        start = i * 12 * STEP_CDEG
        angles = [((start + k * STEP_CDEG) % 36000) / 100 for k in range(12)]
        wire += Packet(3600, start % 36000, (start + 11 * STEP_CDEG) % 36000,
                       (i * 8 // 3) % 30000, tuple(distance_mm(a) for a in angles),
                       (100,) * 12).encode()
    return np.frombuffer(wire, dtype=PACKET_DTYPE)


def range_at(scan: LidarScan, angle_deg: float) -> float:
    index = int(np.argmin(np.abs(np.angle(np.exp(1j * (scan.angles_rad
                                                         - math.radians(angle_deg)))))))
    return float(scan.ranges_m[index])


class TestCutting:
    def test_a_scan_per_turn_after_the_first_partial_one(self) -> None:
        """Packets from 96 deg through 4.5 turns: three whole scans of 450 points each;
        the partial first turn is dropped."""
        assembler = ScanAssembler(LidarConfig())
        first = int(100 / 9.6)
        scans = assembler.add(packets(int(37.5 * 4.5), lambda _a: 1000, first=first), 1.0)
        assert len(scans) == 3
        assert all(abs(len(s.angles_rad) - 450) <= 12 for s in scans)
        assert assembler.counters.scans == 3 and assembler.counters.lost_packets == 0

    def test_packets_one_at_a_time_give_the_same_scans(self) -> None:
        """Adding packets singly or all together cuts the same scans."""
        records = packets(120, lambda a: 500 + int(a))
        together = ScanAssembler(LidarConfig()).add(records, 0.0)
        one_by_one = ScanAssembler(LidarConfig())
        single = [s for i in range(len(records)) for s in one_by_one.add(records[i:i + 1], 0.0)]
        assert len(together) == len(single) == 2
        for a, b in zip(together, single, strict=True):
            np.testing.assert_array_equal(a.ranges_m, b.ranges_m)

    def test_a_turn_still_ends_when_the_packets_around_0_deg_are_lost(self) -> None:
        """Packets from 250 deg to 110 deg of the next turn missing (a noisy line): the drop
        from 240 to 120 deg still ends the scan, where the SDK's 340 -> 20 rule would not."""
        assembler = ScanAssembler(LidarConfig())
        lost = frozenset(range(63, 87))  # 604.8-835.2 deg: 244.8 deg .. 115.2 deg of turn 2
        scans = assembler.add(packets(150, lambda _a: 1000, skip=lost), 0.0)
        assert [len(s.angles_rad) for s in scans] == [12 * 25 + 6, 12 * 25 + 6]

    def test_missing_packets_are_estimated_from_the_timestamps(self) -> None:
        """Three packets missing from the middle: lost_packets 3, the largest gap ~10.7 ms."""
        assembler = ScanAssembler(LidarConfig())
        assembler.add(packets(80, lambda _a: 1000, skip=frozenset({40, 41, 42})), 0.0)
        assert assembler.counters.lost_packets == 3
        assert assembler.counters.max_gap_ms in (10, 11)


class TestGeometry:
    def scan(self, distance_mm: Callable[[float], int], **config: float) -> LidarScan:
        return ScanAssembler(LidarConfig(**config)).add(  # type: ignore[arg-type]
            packets(80, distance_mm), 0.0)[0]

    def test_clockwise_sensor_angles_become_counter_clockwise(self) -> None:
        """Distance 1000 + sensor angle (deg, clockwise): robot angle +90 (left) reads the
        sensor's 270 deg, -90 (right) its 90 deg, 0 its 0."""
        scan = self.scan(lambda a: 1000 + round(a))
        assert range_at(scan, 0) == pytest.approx(1.0, abs=0.002)
        assert range_at(scan, 90) == pytest.approx(1.27, abs=0.002)
        assert range_at(scan, -90) == pytest.approx(1.09, abs=0.002)
        assert np.all(np.diff(scan.angles_rad) >= 0)
        assert scan.angles_rad.min() >= -math.pi and scan.angles_rad.max() < math.pi

    def test_the_mount_yaw_turns_the_scan(self) -> None:
        """A sensor mounted facing left (yaw 90): its 0 deg reads at robot +90 deg."""
        scan = self.scan(lambda a: 1000 + round(a), mount_yaw_deg=90.0)
        assert range_at(scan, 90) == pytest.approx(1.0, abs=0.002)
        assert range_at(scan, 0) == pytest.approx(1.09, abs=0.002)

    def test_the_mount_offset_moves_the_points(self) -> None:
        """A sensor 0.1 m ahead of the centre, walls 1 m around it: 1.1 m ahead, 0.9 m behind."""
        scan = self.scan(lambda _a: 1000, mount_x_m=0.1)
        assert range_at(scan, 0) == pytest.approx(1.1, abs=0.002)
        assert range_at(scan, 180) == pytest.approx(0.9, abs=0.002)
        assert (scan.origin_x_m, scan.origin_y_m) == (0.1, 0.0)

    def test_no_return_and_out_of_range_are_invalid(self) -> None:
        """Distance 0 and beyond max_range_m: NaN range, not valid, not in points_xy()."""
        scan = self.scan(lambda a: 0 if a < 180 else (5000 if a < 270 else 1000),
                         max_range_m=4.0)
        valid = scan.valid
        assert 100 < int(valid.sum()) < 125
        assert np.all(np.isnan(scan.ranges_m[~valid]))
        xy = scan.points_xy()
        assert xy.shape == (int(valid.sum()), 2)
        assert np.allclose(np.hypot(xy[:, 0], xy[:, 1]), 1.0)
