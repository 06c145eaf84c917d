"""Packets -> 360 degree ``LidarScan``s in the robot's frame.

Each packet's twelve points lie evenly from its start to its end angle. A scan ends where
the angle wraps: the sensor only turns one way, so any drop from one point to the next (by
more than 1 deg, for rounding) means 360 deg was passed, even when a noisy line lost the
packets around 0 deg (the SDK's rule, 340 -> under 20 deg, merges turns there). The points
before the first wrap are a partial turn and are dropped, as the SDK drops its first frame.

The LD19's angles grow clockwise seen from above, 0 deg at the arrow on its housing. In the
robot's frame (x forward, y left, angles counter-clockwise) a beam at sensor angle ``s`` points
at ``mount_yaw - s``; its end point is ``mount_offset + range * (cos, sin)``, and the scan
reports angle and range of that point seen from the robot's centre.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from drivers.lidar.config import LidarConfig
from drivers.lidar.packet import (
    FULL_CIRCLE_CDEG,
    POINTS_PER_PACKET,
    TIMESTAMP_WRAP_MS,
)
from drivers.lidar.parser import Records
from drivers.lidar.stats import ScanCounters
from hal.readings import LidarScan

_STEPS = np.arange(POINTS_PER_PACKET, dtype=np.float64)
_CDEG_TO_RAD = math.pi / 18000.0
_WRAP_DROP_CDEG = 100.0


class ScanAssembler:
    """Collects packets' points and cuts them into scans at the angle wrap."""

    def __init__(self, config: LidarConfig, counters: ScanCounters | None = None) -> None:
        self.config = config
        self.counters = counters or ScanCounters()
        self._expected_gap_ms = POINTS_PER_PACKET * 1000.0 / config.model.points_per_s
        self._max_points = 2 * config.model.points_per_s  # two seconds without a wrap
        self._angles: list[npt.NDArray[np.float64]] = []
        self._distances: list[npt.NDArray[np.uint16]] = []
        self._intensities: list[npt.NDArray[np.uint8]] = []
        self._started = False  # a wrap was seen: the points collected begin a turn
        self._last_angle_cdeg: float | None = None
        self._last_timestamp_ms: int | None = None
        self._speed_dps = 0.0

    def reset(self) -> None:
        """Drop the turn in progress (the port was reopened: the next wrap starts afresh)."""
        self._angles, self._distances, self._intensities = [], [], []
        self._started = False
        self._last_angle_cdeg = None
        self._last_timestamp_ms = None

    def add(self, packets: Records, t_s: float) -> list[LidarScan]:
        """Take packets that arrived at ``t_s``; the scans they completed."""
        if len(packets) == 0:
            return []
        self._count_gaps(packets["timestamp_ms"].astype(np.int64))
        self._speed_dps = float(packets["speed_dps"][-1])
        start = packets["start_cdeg"].astype(np.float64)
        span = (packets["end_cdeg"].astype(np.float64) - start + FULL_CIRCLE_CDEG) \
            % FULL_CIRCLE_CDEG
        angles = (start[:, None] + span[:, None] / (POINTS_PER_PACKET - 1) * _STEPS).ravel()
        angles %= FULL_CIRCLE_CDEG
        distances = packets["points"]["distance_mm"].ravel()
        intensities = packets["points"]["intensity"].ravel()
        previous = self._last_angle_cdeg
        self._last_angle_cdeg = float(angles[-1])
        before = np.empty_like(angles)
        before[0] = angles[0] if previous is None else previous
        before[1:] = angles[:-1]
        drops = angles - before
        wraps = np.flatnonzero(drops < -_WRAP_DROP_CDEG).tolist()
        scans: list[LidarScan] = []
        begin = 0
        for wrap in wraps:
            self._collect(angles[begin:wrap], distances[begin:wrap], intensities[begin:wrap])
            if self._started:
                scans.append(self._finish(t_s))
            self._angles, self._distances, self._intensities = [], [], []
            self._started = True
            begin = wrap
        self._collect(angles[begin:], distances[begin:], intensities[begin:])
        if sum(len(a) for a in self._angles) > self._max_points:
            self.reset()  # angles that never wrap are no turn (a sensor fault): start again
        return scans

    def _collect(self, angles: npt.NDArray[np.float64], distances: npt.NDArray[np.uint16],
                 intensities: npt.NDArray[np.uint8]) -> None:
        if len(angles):
            self._angles.append(angles)
            self._distances.append(distances)
            self._intensities.append(intensities)

    def _count_gaps(self, timestamps_ms: npt.NDArray[np.int64]) -> None:
        counters = self.counters
        previous = self._last_timestamp_ms
        self._last_timestamp_ms = int(timestamps_ms[-1])
        if previous is None:
            if len(timestamps_ms) < 2:
                return
            gaps = (timestamps_ms[1:] - timestamps_ms[:-1]) % TIMESTAMP_WRAP_MS
        else:
            before = np.empty_like(timestamps_ms)
            before[0] = previous
            before[1:] = timestamps_ms[:-1]
            gaps = (timestamps_ms - before) % TIMESTAMP_WRAP_MS
        counters.last_gap_ms = int(gaps[-1])
        counters.max_gap_ms = max(counters.max_gap_ms, int(gaps.max()))
        missed = np.rint(gaps / self._expected_gap_ms) - 1
        counters.lost_packets += int(missed[missed > 0].sum())

    def _finish(self, t_s: float) -> LidarScan:
        """The collected turn as a scan in the robot's frame."""
        config = self.config
        sensor_cdeg = np.concatenate(self._angles)
        distances = np.concatenate(self._distances)
        intensities = np.concatenate(self._intensities)
        beam_rad = config.mount_yaw_rad - sensor_cdeg * _CDEG_TO_RAD
        ranges = distances.astype(np.float64) / 1000.0
        valid = (distances > 0) & (ranges >= config.min_range_m) & (ranges <= config.max_range_m)
        ranges[~valid] = np.nan
        if config.mount_x_m or config.mount_y_m:
            x = config.mount_x_m + ranges * np.cos(beam_rad)
            y = config.mount_y_m + ranges * np.sin(beam_rad)
            angles = np.where(valid, np.arctan2(y, x), beam_rad)
            ranges = np.hypot(x, y)
        else:
            angles = beam_rad
        angles = (angles + math.pi) % (2 * math.pi) - math.pi
        order = np.argsort(angles, kind="stable")
        counters = self.counters
        counters.scans += 1
        counters.points_per_scan = len(angles)
        counters.valid_points = int(valid.sum())
        counters.scan_times_s.append(t_s)
        return LidarScan(angles_rad=angles[order], ranges_m=ranges[order],
                         intensities=intensities[order], t_s=t_s, speed_dps=self._speed_dps,
                         origin_x_m=config.mount_x_m, origin_y_m=config.mount_y_m,
                         max_range_m=config.max_range_m)
