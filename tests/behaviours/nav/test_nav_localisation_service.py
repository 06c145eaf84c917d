"""The localisation service on the real LD19 driver and the simulated LD19 (virtual time)."""

from __future__ import annotations

import asyncio
import math
from collections.abc import Callable

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from nav_room import INSIDE, WALLS, grid, scan_at

from behaviours.nav.localisation.config import LocalisationConfig, PeopleConfig
from behaviours.nav.localisation.filter import (
    LIDAR_LOST,
    LOCALISED,
    ODOMETRY_ONLY,
    LocalisedPose,
    Localiser,
)
from behaviours.nav.localisation.people import PeopleTracker
from behaviours.nav.localisation.service import LocalisationService, start_filter
from drivers.lidar import Ld19Lidar, LidarConfig
from hal.latest import LatestValue
from hal.readings import LidarScan
from sim import vclock
from sim.devices.ld19 import SimLd19, walls
from sim.devices.sim_serial import SimSerialPorts

POSE = (2.0, 2.5, 0.4)
RUN_S = 8.0
STALL_S = (3.0, 5.0)


def _run(publish_hz: float) -> tuple[list[LocalisedPose], dict[str, object]]:
    """8 s standing at POSE; the LiDAR stalls from 3 s to 5 s. Every published pose."""

    async def main() -> tuple[list[LocalisedPose], dict[str, object]]:
        loop = asyncio.get_running_loop()
        device = SimLd19(walls(WALLS, x_m=POSE[0], y_m=POSE[1], heading_rad=POSE[2]), seed=3)
        ports = SimSerialPorts()
        ports.attach("/dev/ttyUSB0", device)
        lidar = Ld19Lidar(ports, LidarConfig())
        config = LocalisationConfig(initial_x_m=POSE[0] + 0.1, initial_y_m=POSE[1] - 0.1,
                                    initial_heading_deg=math.degrees(POSE[2] + 0.05),
                                    initial_sigma_m=0.1, publish_hz=publish_hz,
                                    lidar_lost_max_s=1.0)
        localiser = Localiser(grid(), config)
        assert start_filter(localiser) == "config"
        service = LocalisationService(localiser, lidar, lambda: (0.0, 0.0, 0.0))
        poses: list[LocalisedPose] = []
        service.poses.listen(poses.append)
        await lidar.start()
        task = asyncio.create_task(service.run(lambda: None))
        loop.call_later(STALL_S[0], device.stall, True)
        loop.call_later(STALL_S[1], device.stall, False)
        await asyncio.sleep(RUN_S)
        status = service.status()
        task.cancel()
        await asyncio.gather(task, return_exceptions=True)
        await lidar.close()
        device.close()
        return poses, status

    return vclock.run(main())


@pytest.fixture(scope="module")
def run_10hz() -> tuple[list[LocalisedPose], dict[str, object]]:
    return _run(10.0)


@pytest.fixture(scope="module")
def run_default() -> tuple[list[LocalisedPose], dict[str, object]]:
    return _run(LocalisationConfig().publish_hz)


class TestLocalisationService:
    def test_it_localises_on_real_ld19_packets(
            self, run_default: tuple[list[LocalisedPose], dict[str, object]]) -> None:
        """Through the real driver the pose settles within 5 cm / 3 deg of the true one."""
        poses, status = run_default
        last = [p for p in poses if p.t_s < STALL_S[0]][-1]
        assert math.hypot(last.x_m - POSE[0], last.y_m - POSE[1]) < 0.05
        assert abs(math.degrees(math.remainder(last.theta_rad - POSE[2], 2 * math.pi))) < 3
        assert last.status == LOCALISED
        assert status["scans"] and status["status"] == LOCALISED

    def test_a_stalled_lidar_means_odometry_only_then_lidar_lost(
            self, run_default: tuple[list[LocalisedPose], dict[str, object]]) -> None:
        """During the stall the status goes odometry_only, then lidar_lost; scans heal it."""
        poses, _ = run_default
        during = [p.status for p in poses if STALL_S[0] < p.t_s <= STALL_S[1]]
        assert ODOMETRY_ONLY in during and LIDAR_LOST in during
        assert poses[-1].status == LOCALISED

    # Feature: relaybot-autonomous-delivery, Property 15: For any 1-second time window during
    # navigation, the navigation system should provide at least 10 position updates.
    @settings(max_examples=100, deadline=None)
    @given(start_s=st.floats(0.0, RUN_S - 1.0 - 1e-6))
    def test_property_15_ten_poses_in_every_second(
            self, run_10hz: tuple[list[LocalisedPose], dict[str, object]], start_s: float) -> None:
        """Any 1 s window (LiDAR stalled or not) holds >= 10 poses, at the lowest rate, 10 Hz."""
        poses, _ = run_10hz
        count = sum(1 for p in poses if start_s <= p.t_s <= start_s + 1.0)
        assert count >= 10


class _Recording(Localiser):
    """The real filter, remembering the odometry each scan was taken with."""

    def __init__(self, *args: object, **kwargs: object) -> None:
        super().__init__(*args, **kwargs)  # type: ignore[arg-type]
        self.odoms: list[tuple[float, float, float]] = []

    def on_scan(self, odom: tuple[float, float, float], scan: LidarScan, now_s: float, *,
                defer_resample: bool = False) -> bool:
        self.odoms.append(odom)
        return super().on_scan(odom, scan, now_s, defer_resample=defer_resample)


class _ScanSource:
    """Scans handed to listeners as the LD19 driver does, within the caller's loop step."""

    stale = False

    def __init__(self) -> None:
        self.latest: LatestValue[LidarScan] = LatestValue()

    def listen(self, callback: Callable[[LidarScan], object]) -> Callable[[], None]:
        return self.latest.listen(callback)


class TestScanSteps:
    def test_the_update_runs_after_the_lidars_step_with_the_odometry_of_the_scan(self) -> None:
        """The LiDAR's step only queues the filter's update; its resampling and the people
        tracker are the next steps; the filter gets the odometry of the scan's moment, even
        when the wheels have moved on by the time it runs."""

        async def main() -> None:
            source = _ScanSource()
            localiser = _Recording(grid(), LocalisationConfig(
                initial_x_m=INSIDE[0], initial_y_m=INSIDE[1], initial_sigma_m=0.05))
            start_filter(localiser)
            odom = [(0.0, 0.0, 0.0)]
            service = LocalisationService(localiser, source, lambda: odom[-1],  # type: ignore[arg-type]
                                          people=PeopleTracker(PeopleConfig(), None))
            task = asyncio.create_task(service.run(lambda: None))
            await asyncio.sleep(0)
            source.latest.publish(scan_at((*INSIDE, 0.0), np.random.default_rng(1)))
            assert localiser.scans == 0, "not in the LiDAR's own step"
            odom.append((0.3, 0.0, 0.0))  # the wheels turn before the update runs
            await asyncio.sleep(0)
            assert localiser.scans == 1
            assert localiser.odoms == [(0.0, 0.0, 0.0)]
            assert localiser.updates == 1
            assert service.people_out.count == 0, "the people tracker's step comes next"
            particles = localiser.particles.poses.copy()
            await asyncio.sleep(0)
            assert service.people_out.count == 1
            assert not np.array_equal(localiser.particles.poses, particles), "resampled"
            task.cancel()
            await asyncio.gather(task, return_exceptions=True)

        vclock.run(main())
