"""A recorded-style LD19 byte stream with the faults a real line has, and what should survive.

The packets describe a sensor turning at 10 Hz (4500 points/s), timestamps starting just
before the 30000 ms wrap; some distances are 11348 mm (bytes ``54 2C``). Faults between and
in packets: CRC damage (a flipped bit after the header), truncation (a packet cut after 2-46
bytes), stray header bytes and garbage. Built with the driver's encoder: the parser is what
these tests check, the encoder has its own round-trip test.
"""

from __future__ import annotations

import random
from dataclasses import dataclass, field

from drivers.lidar.packet import Packet

HEADER_IN_DISTANCE_MM = 0x2C54  # little-endian: 54 2C
STEP_CDEG = 80  # 3600 deg/s / 4500 points/s = 0.8 deg per point


@dataclass
class Stream:
    data: bytes = b""
    intact: list[Packet] = field(default_factory=list)
    damaged: int = 0  # packets whose header survives but whose bytes do not
    header_in_distance: int = 0  # intact packets with 54 2C in their distances


def turn_packets(count: int, *, start_cdeg: int = 0, timestamp_ms: int = 29900,
                 seed: int = 0) -> list[Packet]:
    """``count`` consecutive intact packets of a 10 Hz LD19."""
    rng = random.Random(seed)
    packets = []
    angle = start_cdeg
    for i in range(count):
        distances = [rng.choice((0, rng.randrange(20, 12000), HEADER_IN_DISTANCE_MM))
                     for _ in range(12)]
        packets.append(Packet(
            speed_dps=3600, start_cdeg=angle % 36000, end_cdeg=(angle + 11 * STEP_CDEG) % 36000,
            timestamp_ms=(timestamp_ms + (i * 8) // 3) % 30000,  # 2.67 ms a packet
            distances_mm=tuple(distances),
            intensities=tuple(rng.randrange(256) for _ in range(12))))
        angle += 12 * STEP_CDEG
    return packets


def faulty_stream(count: int, seed: int, fault_rate: float = 0.3) -> Stream:
    """``count`` packets, a share of them damaged, with stray bytes between them."""
    rng = random.Random(seed)
    stream = Stream()
    out = bytearray()
    for packet in turn_packets(count, seed=seed):
        wire = packet.encode()
        roll = rng.random()
        if roll < fault_rate / 3:
            damaged = bytearray(wire)
            damaged[rng.randrange(2, 47)] ^= 1 << rng.randrange(8)
            out += damaged
            stream.damaged += 1
        elif roll < 2 * fault_rate / 3:
            out += wire[:rng.randrange(2, 47)]
            stream.damaged += 1
        else:
            out += wire
            stream.intact.append(packet)
            stream.header_in_distance += HEADER_IN_DISTANCE_MM in packet.distances_mm
        if rng.random() < fault_rate / 3:
            out += rng.choice((b"\x54", b"\x54\x2c", b"\x2c\x54", bytes([0x54, 0x2C, 0x00]),
                               bytes(rng.randrange(256) for _ in range(rng.randrange(1, 20)))))
    stream.data = bytes(out)
    return stream
