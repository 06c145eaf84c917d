"""A simulated LD19 (or STL-19P) LiDAR: real 47-byte packets on a byte line, paced like one.

``SimLd19`` turns at 10 Hz and measures 4500 points/s (the STL-19P 5000), asks a caller's
``ranges(angles_rad) -> ranges_m`` function what each beam hits (angles in the sensor's own
counter-clockwise frame, 0 = its arrow; inf or NaN = nothing), adds the sensor's noise
(sigma 10 mm, quantised to 1 mm), reports no return (distance 0) past its range, and writes
the packets to its end of the line once per ``chunk_s`` of virtual time (never a wake-up per
byte). Bench-style faults: ``unplug(duration_s)``, ``corrupt(pct)``, ``stall()``.

The packet encoder and CRC here are written apart from ``drivers.lidar`` on purpose (``hal``
does not import drivers, and the fake must check the driver, not itself): the table is
computed from LDROBOT's polynomial 0x4D; the wire angles grow clockwise, as the LD19's do.
"""

from __future__ import annotations

import asyncio
import math
from collections.abc import Callable, Sequence
from typing import Protocol

import numpy as np
import numpy.typing as npt
import structlog

from hal.ports import StreamPair

log = structlog.get_logger(__name__)

RangeFunction = Callable[[npt.NDArray[np.float64]], npt.NDArray[np.float64]]
Segment = tuple[float, float, float, float]

POINTS = 12
PACKET_BYTES = 47
POINTS_PER_S = {"ld19": 4500, "stl19p": 5000}
_DTYPE = np.dtype([
    ("header", "u1"), ("ver_len", "u1"), ("speed", "<u2"), ("start", "<u2"),
    ("points", [("distance", "<u2"), ("intensity", "u1")], (POINTS,)),
    ("end", "<u2"), ("timestamp", "<u2"), ("crc", "u1"),
])


def _crc_by_position(polynomial: int = 0x4D, length: int = PACKET_BYTES - 1
                     ) -> npt.NDArray[np.uint8]:
    """[i, b]: CRC-8 of ``length`` zero bytes but ``b`` at i. The CRC (init 0) is linear, so
    a packet's CRC is the xor of its bytes' entries: no loop over the 46 columns."""
    step = []
    for byte in range(256):
        crc = byte
        for _ in range(8):
            crc = ((crc << 1) ^ polynomial) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
        step.append(crc)
    table = np.zeros((length, 256), dtype=np.uint8)
    crc_of = np.array(step, dtype=np.uint8)
    for position in range(length - 1, -1, -1):
        table[position] = crc_of
        crc_of = np.array(step, dtype=np.uint8)[crc_of]
    return table


_CRC_BY_POSITION = _crc_by_position()
_COLUMNS = np.arange(PACKET_BYTES - 1)


class _Line(Protocol):
    """The device's side of a simulated serial line (``sim`` byte pipe)."""

    b: StreamPair

    def break_(self) -> None: ...


class SimLd19:
    """A spinning LD19 that writes packets to the serial line it is connected to.

    Args:
        ranges: what each beam hits; replace ``ranges`` at any time (the world moves).
        model: ``ld19`` (4500 points/s) or ``stl19p`` (5000).
        rotation_hz: turns per second (the speed field says this x 360 deg/s).
        seed: seed of the noise and the corruption.
    """

    def __init__(self, ranges: RangeFunction, *, model: str = "ld19", rotation_hz: float = 10.0,
                 noise_m: float = 0.010, max_range_m: float = 12.0, chunk_s: float = 0.010,
                 seed: int = 0) -> None:
        self.ranges = ranges
        self.points_per_s = POINTS_PER_S[model]
        self.rotation_hz = rotation_hz
        self.noise_m = noise_m
        self.max_range_m = max_range_m
        self.chunk_s = chunk_s
        self.plugged = True
        self.stalled = False
        self.corrupt_fraction = 0.0
        self.packets_sent = 0
        self.bytes_sent = 0
        self.writes = 0
        self._rng = np.random.default_rng(seed)
        self._line: _Line | None = None
        self._timer: asyncio.TimerHandle | None = None
        self._replug: asyncio.TimerHandle | None = None
        self._t0_s = 0.0
        self.packets_due = 0.0
        self._angle_cdeg = 0.0  # clockwise angle of the next point

    # -- the line ----------------------------------------------------------------------------
    def connect_pipe(self, pipe: _Line) -> None:
        """Start talking on the device end of a line (what ``SimSerialPorts`` calls)."""
        self.disconnect()
        self._line = pipe
        loop = asyncio.get_running_loop()
        self._t0_s = loop.time()
        self.packets_due = 0.0
        self._timer = loop.call_at(self._t0_s + self.chunk_s, self._tick)

    def disconnect(self) -> None:
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None
        self._line = None

    def close(self) -> None:
        self.disconnect()
        if self._replug is not None:
            self._replug.cancel()
            self._replug = None

    # -- faults ------------------------------------------------------------------------------
    def unplug(self, duration_s: float | None = None) -> None:
        """The USB cable is pulled (for ``duration_s``, or until ``replug()``)."""
        self.plugged = False
        line = self._line
        self.disconnect()
        if line is not None:
            line.break_()
        log.info("sim_ld19.unplugged", duration_s=duration_s)
        if duration_s is not None:
            self._replug = asyncio.get_running_loop().call_later(duration_s, self.replug)

    def replug(self) -> None:
        self.plugged = True
        self._replug = None
        log.info("sim_ld19.replugged")

    def corrupt(self, pct: float) -> None:
        """Flip one bit in ``pct`` % of the bytes sent."""
        self.corrupt_fraction = max(0.0, min(100.0, pct)) / 100.0

    def stall(self, stalled: bool = True) -> None:
        """The motor stops: the port stays open and silent (``stall(False)`` restarts it)."""
        self.stalled = stalled
        log.info("sim_ld19.stall", stalled=stalled)

    # -- packets -----------------------------------------------------------------------------
    def _tick(self) -> None:
        loop = asyncio.get_running_loop()
        now_s = loop.time()
        self._timer = loop.call_at(now_s + self.chunk_s, self._tick)
        self.packets_due += self.chunk_s * self.points_per_s / POINTS
        count = int(self.packets_due)
        if count == 0 or self.stalled or self._line is None:
            self.packets_due -= count
            return
        self.packets_due -= count
        data = self.packets(count)
        try:
            self._line.b[1].write(data)
            self.writes += 1
        except OSError:
            self.disconnect()

    def packets(self, count: int) -> bytes:
        """The next ``count`` packets of the turn, as bytes (faults applied)."""
        speed_dps = self.rotation_hz * 360.0
        step_cdeg = speed_dps / self.points_per_s * 100.0
        first = self._angle_cdeg + step_cdeg * np.arange(count * POINTS)
        self._angle_cdeg = float((first[-1] + step_cdeg) % 36000.0)
        cw_cdeg = first % 36000.0
        ranges_m = np.asarray(self.ranges(-np.radians(cw_cdeg / 100.0)), dtype=np.float64)
        noisy = ranges_m + self._rng.normal(0.0, self.noise_m, ranges_m.shape)
        hit = np.isfinite(noisy) & (noisy > 0.0) & (noisy <= self.max_range_m)
        noisy[~hit] = 0.0
        distance_mm = np.where(hit, np.rint(noisy * 1000.0).clip(1, 65535), 0)
        intensity = np.where(hit, np.clip(240 - 15 * noisy, 40, 240), 0)
        records = np.zeros(count, dtype=_DTYPE)
        records["header"], records["ver_len"] = 0x54, 0x2C
        records["speed"] = round(speed_dps)
        records["start"] = np.rint(cw_cdeg[::POINTS]).astype(np.int64) % 36000
        records["end"] = np.rint(cw_cdeg[POINTS - 1::POINTS]).astype(np.int64) % 36000
        records["points"]["distance"] = distance_mm.reshape(count, POINTS)
        records["points"]["intensity"] = intensity.reshape(count, POINTS)
        # The sensor's ms clock at each packet's first point (it counts from power-on).
        index = self.packets_sent + np.arange(count)
        records["timestamp"] = np.floor(index * POINTS * 1000.0 / self.points_per_s) % 30000
        rows = records.view(np.uint8).reshape(count, PACKET_BYTES)
        rows[:, PACKET_BYTES - 1] = np.bitwise_xor.reduce(
            _CRC_BY_POSITION[_COLUMNS, rows[:, :PACKET_BYTES - 1]], axis=1)
        if self.corrupt_fraction > 0.0:
            flat = rows.reshape(-1)
            hits = np.flatnonzero(self._rng.random(flat.size) < self.corrupt_fraction)
            flat[hits] ^= (1 << self._rng.integers(0, 8, hits.size)).astype(np.uint8)
        self.packets_sent += count
        self.bytes_sent += rows.size
        return rows.tobytes()


def walls(segments: Sequence[Segment], *, x_m: float = 0.0, y_m: float = 0.0,
          heading_rad: float = 0.0) -> RangeFunction:
    """A ``ranges`` function for a sensor at (x, y, heading) among wall segments
    ``(x1, y1, x2, y2)``: the nearest hit along each beam, inf where none."""
    seg = np.asarray(segments, dtype=np.float64).reshape(-1, 4)
    ax, ay = seg[:, 0] - x_m, seg[:, 1] - y_m
    ex, ey = seg[:, 2] - seg[:, 0], seg[:, 3] - seg[:, 1]

    def ranges(angles_rad: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        dx = np.cos(angles_rad + heading_rad)[:, None]
        dy = np.sin(angles_rad + heading_rad)[:, None]
        denom = dx * ey - dy * ex  # beam x segment direction
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (ax * ey - ay * ex) / denom  # distance along the beam
            u = (ax * dy - ay * dx) / denom  # position along the segment, 0-1
        hit = (np.abs(denom) > 1e-12) & (t > 0) & (u >= 0) & (u <= 1)
        nearest: npt.NDArray[np.float64] = np.where(hit, t, math.inf).min(axis=1,
                                                                           initial=math.inf)
        return nearest

    return ranges
