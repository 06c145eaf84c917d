"""The real LD19 driver reading the simulated LD19's bytes, in virtual time."""

from __future__ import annotations

import asyncio
import math
from collections.abc import Awaitable, Callable

import numpy as np
import pytest
from structlog.testing import capture_logs

import drivers.lidar
from drivers.lidar import Ld19Lidar, LidarConfig, Model
from hal.devices import DeviceUnavailable, Lidar, LidarStale
from hal.readings import LidarScan
from robotd.config.errors import ConfigError
from robotd.config.loader import defaults, load_config_text
from robotd.config.settings import Settings
from sim import vclock
from sim.devices.ld19 import SimLd19, walls
from sim.devices.sim_serial import SimSerialPorts

PORT = "/dev/ttyUSB0"
# A room around the sensor: a wall 1 m ahead (x), 2 m to the left (y), 3 m right and behind.
ROOM = [(1.0, -3.0, 1.0, 2.0), (-3.0, 2.0, 1.0, 2.0), (-3.0, -3.0, 1.0, -3.0),
        (-3.0, -3.0, -3.0, 2.0)]


def range_at(scan: LidarScan, angle_deg: float) -> float:
    error = np.abs(np.angle(np.exp(1j * (scan.angles_rad - math.radians(angle_deg)))))
    return float(scan.ranges_m[int(np.argmin(error))])


def on_bench(scenario: Callable[[SimLd19, Ld19Lidar], Awaitable[None]], *,
             config: LidarConfig | None = None, model: str = "ld19") -> None:
    async def main() -> None:
        device = SimLd19(walls(ROOM), model=model, seed=4)
        ports = SimSerialPorts()
        ports.attach(PORT, device)
        lidar = Ld19Lidar(ports, config or LidarConfig(port=PORT))
        await lidar.start()
        try:
            await scenario(device, lidar)
        finally:
            await lidar.close()
            device.close()

    vclock.run(main())


class TestScans:
    def test_a_wall_1_m_ahead_reads_1_m_at_0_and_left_is_plus_90(self) -> None:
        """Through the real driver: 1 m at 0 deg, the left wall 2 m at +90, the right 3 m
        at -90, behind 3 m at 180; noise within 4 sigma; 450 points at 10 Hz."""

        async def scenario(_device: SimLd19, lidar: Ld19Lidar) -> None:
            assert isinstance(lidar, Lidar)
            await asyncio.sleep(1.0)
            scan = await lidar.next_reading()
            assert range_at(scan, 0) == pytest.approx(1.0, abs=0.04)
            assert range_at(scan, 90) == pytest.approx(2.0, abs=0.04)
            assert range_at(scan, -90) == pytest.approx(3.0, abs=0.04)
            assert range_at(scan, 180) == pytest.approx(3.0, abs=0.04)
            assert len(scan.angles_rad) == 450 and bool(scan.valid.all())
            x_ahead = scan.points_xy()[:, 0].max()
            assert x_ahead == pytest.approx(1.0, abs=0.04)
            status = lidar.status()
            assert status["scan_rate_hz"] == pytest.approx(10.0, abs=0.1)
            assert status["crc_errors"] == status["lost_packets"] == 0
            assert not status["stale"] and status["connected"]

        on_bench(scenario)

    def test_the_stl19p_gives_500_points_a_turn(self) -> None:
        """The STL-19P measures 5000 points/s: 500 per 10 Hz scan, through the same driver."""

        async def scenario(_device: SimLd19, lidar: Ld19Lidar) -> None:
            await asyncio.sleep(0.5)
            scan = await lidar.next_reading()
            assert len(scan.angles_rad) == 500
            assert lidar.status()["implausible"] == 0

        on_bench(scenario, model="stl19p",
                 config=LidarConfig(port=PORT, model=Model.STL19P))

    def test_a_corrupted_line_still_gives_scans_and_counts_the_damage(self) -> None:
        """1 % of bytes flipped (~38 % of packets damaged): scans keep coming at 10 Hz with
        fewer points; CRC errors and resyncs counted; nothing raises."""

        async def scenario(device: SimLd19, lidar: Ld19Lidar) -> None:
            device.corrupt(1.0)
            await asyncio.sleep(3.0)
            status = lidar.status()
            assert status["crc_errors"] > 100 and status["resyncs"] > 50
            assert status["scan_rate_hz"] == pytest.approx(10.0, abs=0.5)
            assert 200 < status["points_per_scan"] < 400
            assert range_at(await lidar.next_reading(), 0) == pytest.approx(1.0, abs=0.04)

        on_bench(scenario)


class TestFaults:
    def test_unplugged_it_goes_stale_then_reconnects_and_scans_again(self) -> None:
        """Unplug for 2 s: connected False, a lidar.stale event, the stale callback, waiters
        get LidarStale; replugged: it reconnects by itself and scans resume."""

        async def scenario(device: SimLd19, lidar: Ld19Lidar) -> None:
            changes: list[bool] = []
            lidar.on_stale_change(changes.append)
            await asyncio.sleep(0.5)
            with capture_logs() as logs:
                device.unplug(2.0)
                waiter = asyncio.ensure_future(lidar.next_reading())
                with pytest.raises(LidarStale, match="port down"):
                    await waiter
                assert lidar.stale and not lidar.connected
                with pytest.raises(LidarStale):
                    await lidar.next_reading()
                await asyncio.sleep(2.0 + 5.0)
            assert not lidar.stale and lidar.connected
            assert changes == [True, False]
            assert lidar.status()["reconnects"] == 1
            events = [e["event"] for e in logs]
            assert "lidar.stale" in events and "lidar.fresh" in events
            assert range_at(await lidar.next_reading(), 0) == pytest.approx(1.0, abs=0.04)

        on_bench(scenario)

    def test_a_stalled_motor_is_stale_within_stale_s_with_the_port_open(self) -> None:
        """The motor stops (port open, silent): stale after lidar.stale_s; restarts: fresh."""

        async def scenario(device: SimLd19, lidar: Ld19Lidar) -> None:
            await asyncio.sleep(0.5)
            loop = asyncio.get_running_loop()
            device.stall()
            stalled_at = loop.time()
            changes: list[float] = []
            lidar.on_stale_change(lambda _stale: changes.append(loop.time()))
            await asyncio.sleep(1.0)
            assert lidar.stale and lidar.connected
            assert 0.3 <= changes[0] - stalled_at <= 0.5 + 0.02
            device.stall(False)
            await asyncio.sleep(0.5)
            assert not lidar.stale

        on_bench(scenario, config=LidarConfig(port=PORT, stale_s=0.4))

    def test_start_without_a_device_names_the_port(self) -> None:
        """No device at the port: DeviceUnavailable that says which port and why."""

        async def main() -> None:
            lidar = Ld19Lidar(SimSerialPorts(), LidarConfig(port="/dev/ttyUSB7"))
            with pytest.raises(DeviceUnavailable, match=r"/dev/ttyUSB7.*cannot open"):
                await lidar.start()

        vclock.run(main())

    def test_start_on_a_silent_port_says_no_packets(self) -> None:
        """A port that opens but carries no LD19 packets: DeviceUnavailable within 3 s."""

        async def main() -> None:
            device = SimLd19(walls(ROOM))
            device.stall()
            ports = SimSerialPorts()
            ports.attach(PORT, device)
            lidar = Ld19Lidar(ports, LidarConfig(port=PORT))
            with pytest.raises(DeviceUnavailable, match="no LD19 packets"):
                await lidar.start()
            device.close()

        vclock.run(main())


class TestFromSettings:
    def test_the_factory_reads_the_lidar_section(self) -> None:
        """drivers.lidar.from_settings (robotd.hardware's factory) takes port, model, mount."""
        values = defaults()
        values["lidar"].update(port="/dev/ttyUSB3", model="stl19p", mount_yaw_deg=180.0)
        lidar = drivers.lidar.from_settings(Settings(values))
        assert lidar.config.port == "/dev/ttyUSB3" and lidar.config.model is Model.STL19P
        assert lidar.config.mount_yaw_rad == pytest.approx(math.pi)
        assert lidar.config.baud == 230400 and lidar.config.stale_s == 0.5

    def test_check_config_names_a_bad_lidar_key_and_its_line(self) -> None:
        """An unknown model, or a min range above the max: the line and section.key named."""
        with pytest.raises(ConfigError) as excinfo:
            load_config_text('[lidar]\nmodel = "ld99"\n', "robotd.toml")
        assert str(excinfo.value).startswith(
            "robotd.toml:2: lidar.model: expected one of 'ld19', 'stl19p', got 'ld99'")
        with pytest.raises(ConfigError, match=r"lidar\.(min|max)_range_m"):
            load_config_text("[lidar]\nmin_range_m = 5.0\nmax_range_m = 4.0\n", "robotd.toml")
