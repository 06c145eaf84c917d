"""Seed property 14: the LiDAR gives at least 10 scans in every second of operation, through
the real driver on the simulated LD19 (real packets at the line rate, virtual time)."""

from __future__ import annotations

import asyncio

from hypothesis import given, settings
from hypothesis import strategies as st

from drivers.lidar import Ld19Lidar, LidarConfig
from hal.readings import LidarScan
from sim import vclock
from sim.devices.ld19 import SimLd19, walls
from sim.devices.sim_serial import SimSerialPorts

PORT = "/dev/ttyUSB0"
ARRIVAL_SLACK_S = 0.011
"""A turn's last packet reaches the host in the serial line's next batch (the simulated LD19
writes every 10 ms, as a USB-serial adapter delivers): a turn that ends inside a window can be
seen up to that much after it. At exactly 10 Hz a window of exactly 1 s measured on arrival
times would otherwise hold 9 turns whenever it starts just after one."""
ROOM = [((-1.0, -2.0), (-1.0, 2.0)), ((-1.0, 2.0), (3.0, 2.0)),
        ((3.0, 2.0), (3.0, -2.0)), ((3.0, -2.0), (-1.0, -2.0))]


def scan_times(model: str, seed: int, corrupt_pct: float, seconds: float) -> list[float]:
    """When each whole scan reached a behaviour, over ``seconds`` after the driver started."""

    async def main() -> list[float]:
        device = SimLd19(walls(ROOM), model=model, seed=seed)
        device.corrupt(corrupt_pct)
        ports = SimSerialPorts()
        ports.attach(PORT, device)
        lidar = Ld19Lidar(ports, LidarConfig(port=PORT))
        await lidar.start()
        loop = asyncio.get_running_loop()
        times: list[float] = []

        def heard(_scan: LidarScan) -> None:
            times.append(loop.time())

        stop = lidar.listen(heard)
        start = loop.time()
        await asyncio.sleep(seconds)
        stop()
        await lidar.close()
        device.close()
        return [t - start for t in times]

    return vclock.run(main())


# Feature: relaybot-autonomous-delivery, Property 14: For any 1-second time window during
# operation, the LiDAR system should provide at least 10 scan updates.
@settings(max_examples=100, deadline=None)
@given(model=st.sampled_from(["ld19", "stl19p"]), seed=st.integers(0, 2**16),
       corrupt_pct=st.sampled_from([0.0, 0.1, 0.5]), offset_s=st.floats(0.0, 1.0))
def test_property_14_every_second_has_at_least_10_scans(model: str, seed: int,
                                                        corrupt_pct: float,
                                                        offset_s: float) -> None:
    """Once scans flow (operation: from the first whole turn on), any 1 s window holds >= 10
    of them: the window from ``offset_s`` after the first, and the one starting at every scan
    (the LD19 turns at 10 Hz; rare CRC damage drops packets, not whole turns)."""
    times = scan_times(model, seed, corrupt_pct, 2.6)
    starts = [times[0] + offset_s, *(t for t in times if t <= times[0] + 1.0)]
    for start in starts:
        in_window = [t for t in times if start <= t < start + 1.0 + ARRIVAL_SLACK_S]
        assert len(in_window) >= 10, (start, len(in_window), times)
