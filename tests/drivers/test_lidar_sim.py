"""The simulated LD19 on its own: real packets (checked by the driver's decoder), paced at the
real rates, with the sensor's noise, dropouts and faults."""

from __future__ import annotations

import asyncio
import errno
import itertools
import math

import numpy as np
import pytest

from drivers.lidar.packet import PACKET_BYTES, Packet
from sim import vclock
from sim.devices.ld19 import SimLd19, walls
from sim.devices.sim_serial import SimSerialPorts

PORT = "/dev/ttyUSB0"


def decode_all(data: bytes) -> list[Packet]:
    assert len(data) % PACKET_BYTES == 0
    return [Packet.decode(data[i:i + PACKET_BYTES]) for i in range(0, len(data), PACKET_BYTES)]


def record(device: SimLd19, seconds: float, during: float = 0.0) -> bytes:
    """What arrives at the host end of the line over ``seconds`` of virtual time."""

    async def main() -> bytes:
        ports = SimSerialPorts()
        ports.attach(PORT, device)
        reader, _writer = await ports(PORT, 230400)
        await asyncio.sleep(seconds)
        data = b""
        while not reader.at_eof() and len(reader._buffer):  # type: ignore[attr-defined]
            data += await reader.read(1 << 20)
        device.close()
        return data

    return vclock.run(main())


class TestPackets:
    def test_a_second_of_ld19_is_375_valid_packets_in_about_100_writes(self) -> None:
        """4500 points/s: 375 packets a second, each decoding with the driver's CRC check,
        3600 deg/s, 8.8 deg from first to last point, written ~100 times (every 10 ms)."""
        device = SimLd19(lambda a: np.full_like(a, 2.0))
        packets = decode_all(record(device, 1.0))
        assert abs(len(packets) - 375) <= 8  # the first write at 10 ms, the last on the wire
        assert 95 <= device.writes <= 101
        assert {p.speed_dps for p in packets} == {3600}
        spans = {(p.end_cdeg - p.start_cdeg) % 36000 for p in packets}
        assert spans <= {879, 880, 881}
        gaps = {(b.timestamp_ms - a.timestamp_ms) % 30000 for a, b in itertools.pairwise(packets)}
        assert gaps <= {2, 3}

    def test_the_stl19p_measures_5000_points_a_second(self) -> None:
        """The STL-19P: 417 packets a second, 7.92 deg from first to last point."""
        packets = decode_all(record(SimLd19(lambda a: np.full_like(a, 2.0), model="stl19p"), 1.0))
        assert abs(len(packets) - 417) <= 8  # the first write at 10 ms, the last on the wire
        assert {(p.end_cdeg - p.start_cdeg) % 36000 for p in packets} <= {791, 792, 793}

    def test_noise_is_10_mm_and_beyond_range_is_no_return(self) -> None:
        """A wall at 1.5 m reads with sigma ~10 mm in whole mm; beams to 20 m or nowhere: 0."""

        def ranges(angles: np.ndarray) -> np.ndarray:  # type: ignore[type-arg]
            return np.where(np.cos(angles) > 0, 1.5, np.where(np.sin(angles) > 0, 20.0, math.inf))

        packets = decode_all(record(SimLd19(ranges, seed=3), 2.0))
        distances = np.array([p.distances_mm for p in packets]).ravel()
        hits = distances[distances > 0]
        assert 0.45 < len(hits) / len(distances) < 0.55
        assert np.mean(hits) == pytest.approx(1500, abs=1.5)
        assert np.std(hits) == pytest.approx(10.0, abs=1.0)

    def test_the_sensor_clock_wraps_at_30000_ms(self) -> None:
        """Timestamps count milliseconds from power-on and wrap at 30000."""
        device = SimLd19(lambda a: np.full_like(a, 2.0))
        packets = decode_all(device.packets(31 * 375))
        stamps = [p.timestamp_ms for p in packets]
        assert max(stamps) < 30000 and stamps.count(0) == 2


class TestFaults:
    def test_corrupt_flips_about_that_share_of_bytes(self) -> None:
        """corrupt(2): ~2 % of the bytes differ from a clean twin's."""
        clean = SimLd19(walls([(1, -1, 1, 1)]), seed=5, noise_m=0.0).packets(400)
        noisy_device = SimLd19(walls([(1, -1, 1, 1)]), seed=5, noise_m=0.0)
        noisy_device.corrupt(2.0)
        noisy = noisy_device.packets(400)
        differing = np.count_nonzero(np.frombuffer(clean, np.uint8) != np.frombuffer(noisy,
                                                                                     np.uint8))
        assert differing / len(clean) == pytest.approx(0.02, abs=0.004)

    def test_stall_silences_the_line_and_unplug_removes_the_port_for_a_while(self) -> None:
        """Stalled: no bytes, the port open; unplugged for 1 s: opening fails, then works."""

        async def main() -> None:
            device = SimLd19(lambda a: np.full_like(a, 2.0))
            ports = SimSerialPorts()
            ports.attach(PORT, device)
            await ports(PORT, 230400)
            device.stall()
            sent = device.bytes_sent
            await asyncio.sleep(0.5)
            assert device.bytes_sent == sent
            device.stall(False)
            device.unplug(1.0)
            with pytest.raises(FileNotFoundError) as excinfo:
                await ports(PORT, 230400)
            assert excinfo.value.errno == errno.ENOENT
            await asyncio.sleep(1.01)
            await ports(PORT, 230400)
            await asyncio.sleep(0.1)
            assert device.bytes_sent > sent
            device.close()

        vclock.run(main())
