"""The LD19's 47-byte measurement packet: its fields, and encode/decode of one packet.

Layout (little-endian), as LDROBOT's ``LiDARFrameTypeDef``::

    0      header   0x54
    1      ver_len  0x2C  (version 1, 12 points)
    2-3    speed    deg/s
    4-5    start    angle of the first point, 0.01 deg (clockwise)
    6-41   12 x (distance u16 mm, intensity u8)
    42-43  end      angle of the last point, 0.01 deg
    44-45  timestamp  ms, wraps at 30000
    46     crc      CRC-8 of bytes 0-45 (``drivers.lidar.crc``)

The twelve points are spread evenly from start to end: step = ((end - start + 36000) %
36000) / 11, as ``LiPkg::Parse`` in LDROBOT's SDK does (it divides integers; we keep the
hundredths).
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from enum import Enum

import numpy as np
import numpy.typing as npt

from drivers.lidar.crc import crc8

HEADER = 0x54
VER_LEN = 0x2C
HEADER_BYTES = bytes((HEADER, VER_LEN))
PACKET_BYTES = 47
POINTS_PER_PACKET = 12
TIMESTAMP_WRAP_MS = 30000
FULL_CIRCLE_CDEG = 36000
LINE_BAUD = 230400
LINE_BYTES_PER_S = LINE_BAUD / 10  # 8N1: ten bit times a byte

PACKET_DTYPE = np.dtype([
    ("header", "u1"), ("ver_len", "u1"), ("speed_dps", "<u2"), ("start_cdeg", "<u2"),
    ("points", [("distance_mm", "<u2"), ("intensity", "u1")], (POINTS_PER_PACKET,)),
    ("end_cdeg", "<u2"), ("timestamp_ms", "<u2"), ("crc", "u1"),
])
"""One packet as a numpy record (47 bytes, packed): ``np.frombuffer`` decodes many at once."""
assert PACKET_DTYPE.itemsize == PACKET_BYTES

_STRUCT = struct.Struct("<BBHH" + "HB" * POINTS_PER_PACKET + "HH")


class Model(Enum):
    """LDROBOT sensors that speak this packet, with their measuring rate."""

    LD19 = "ld19"
    STL19P = "stl19p"

    @property
    def points_per_s(self) -> int:
        return 4500 if self is Model.LD19 else 5000


@dataclass(frozen=True, slots=True)
class Packet:
    """One packet's fields; distances in mm (0 = no return), angles in 0.01 deg clockwise."""

    speed_dps: int
    start_cdeg: int
    end_cdeg: int
    timestamp_ms: int
    distances_mm: tuple[int, ...]
    intensities: tuple[int, ...]

    def encode(self) -> bytes:
        """The 47 bytes on the wire, CRC included."""
        points: list[int] = []
        for distance, intensity in zip(self.distances_mm, self.intensities, strict=True):
            points += (distance, intensity)
        body = _STRUCT.pack(HEADER, VER_LEN, self.speed_dps, self.start_cdeg, *points,
                            self.end_cdeg, self.timestamp_ms)
        return body + bytes((crc8(body),))

    @classmethod
    def decode(cls, data: bytes) -> Packet:
        """Fields of 47 bytes; ValueError naming what is wrong (header, length, CRC)."""
        if len(data) != PACKET_BYTES:
            msg = f"LD19 packet: {len(data)} bytes, expected {PACKET_BYTES}"
            raise ValueError(msg)
        if data[:2] != HEADER_BYTES:
            msg = f"LD19 packet: header {data[:2].hex()}, expected 542c"
            raise ValueError(msg)
        if crc8(data[:46]) != data[46]:
            msg = f"LD19 packet: CRC {data[46]:02x}, computed {crc8(data[:46]):02x}"
            raise ValueError(msg)
        fields = _STRUCT.unpack(data[:46])
        points = fields[4:4 + 2 * POINTS_PER_PACKET]
        return cls(speed_dps=fields[2], start_cdeg=fields[3], end_cdeg=fields[-2],
                   timestamp_ms=fields[-1], distances_mm=tuple(points[0::2]),
                   intensities=tuple(points[1::2]))


def from_records(records: npt.NDArray[np.void]) -> list[Packet]:
    """``PACKET_DTYPE`` records (what the parser returns) as ``Packet``s."""
    return [Packet(speed_dps=int(r["speed_dps"]), start_cdeg=int(r["start_cdeg"]),
                   end_cdeg=int(r["end_cdeg"]), timestamp_ms=int(r["timestamp_ms"]),
                   distances_mm=tuple(int(d) for d in r["points"]["distance_mm"]),
                   intensities=tuple(int(i) for i in r["points"]["intensity"]))
            for r in records]


def span_cdeg(start_cdeg: int, end_cdeg: int) -> int:
    """Angle covered from the first to the last point, across 360 deg."""
    return (end_cdeg - start_cdeg + FULL_CIRCLE_CDEG) % FULL_CIRCLE_CDEG


def expected_span_cdeg(speed_dps: float, points_per_s: int) -> float:
    """The span eleven point intervals cover at ``speed_dps``."""
    return speed_dps * (POINTS_PER_PACKET - 1) / points_per_s * 100.0
