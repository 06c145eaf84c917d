"""The BLE scanner's watchdog: a stalled, refusing or powered-off adapter is restarted."""

from __future__ import annotations

import asyncio
import random
from typing import Any

import pytest
from bleak.exc import BleakDBusError

from drivers.ble_scanner import BleBeaconScanner
from hal.devices import DeviceUnavailable
from hal.readings import BeaconSighting
from sim import vclock
from sim.devices.ble_model import SimBleAir
from sim.world.body import DiffDriveBody
from sim.world.floor_plan import World
from sim.world.geometry import Pose

UUID = "fda50693-a4e2-4fb1-afcf-c6eb07647825"


def _air() -> SimBleAir:
    world = World.from_table({"width_m": 8, "height_m": 4, "beacons": [
        {"mac": "C3:00:00:00:01:03", "uuid": UUID, "major": 1, "minor": 103,
         "x_m": 6.0, "y_m": 2.0}]})
    return SimBleAir(DiffDriveBody(world, Pose(2.0, 2.0, 0.0)), rng=random.Random(7))


class TestScannerRecovery:
    def test_stalled_adapter_is_restarted_and_adverts_resume(self) -> None:
        """No advert for stall_timeout_s → the scan restarts and sightings flow again."""
        async def main() -> None:
            air = _air()
            driver = BleBeaconScanner([UUID], scanner_factory=air.scanner_factory(),
                                      stall_timeout_s=5.0)
            seen: list[BeaconSighting] = []
            driver.on_sighting(seen.append)
            async with air.running():
                await driver.start()
                await asyncio.sleep(3)
                air.stall()
                stalled_at = len(seen)
                await asyncio.sleep(4)
                assert len(seen) == stalled_at
                await asyncio.sleep(5)
                assert driver.counts["restarts"] == 1
                assert len(seen) > stalled_at
                await driver.close()
            assert air.counts["starts"] == 2

        vclock.run(main())

    def test_bluez_in_progress_errors_back_off_then_recover(self) -> None:
        """Restarts refused with org.bluez.Error.InProgress are retried with growing delays."""
        async def main() -> None:
            air = _air()
            driver = BleBeaconScanner([UUID], scanner_factory=air.scanner_factory(),
                                      stall_timeout_s=2.0, restart_base_s=0.5)
            seen: list[BeaconSighting] = []
            driver.on_sighting(seen.append)
            loop = asyncio.get_running_loop()
            async with air.running():
                await driver.start()
                await asyncio.sleep(1)
                air.fail_next_starts(3)
                air.stall()
                t_stall = loop.time()
                errors_shown = set()
                for _ in range(300):
                    errors_shown.add(driver.status()["last_error"])
                    if driver.counts["restarts"] == 4:
                        break
                    await asyncio.sleep(0.1)
                recovered_after_s = loop.time() - t_stall
                await asyncio.sleep(2)
                await driver.close()
            assert driver.counts["scan_errors"] == 3
            assert any("org.bluez.Error.InProgress" in (e or "") for e in errors_shown)
            assert driver.last_error is None  # adverts flow again: no live problem to show
            # 2 s stall + four backoff waits (0.5, 1, 2, 4 s) plus the watchdog's checks
            assert 9.5 <= recovered_after_s <= 12
            assert seen[-1].t_s > t_stall + recovered_after_s
            assert driver.status()["backoff_s"] == 0.5  # reset once adverts flowed again

        vclock.run(main())

    def test_powered_off_adapter_is_retried_until_it_is_back(self) -> None:
        """Powered off: starts fail (counted) until power returns, then scanning resumes."""
        async def main() -> None:
            air = _air()
            driver = BleBeaconScanner([UUID], scanner_factory=air.scanner_factory(),
                                      stall_timeout_s=2.0, restart_max_s=4.0)
            async with air.running():
                await driver.start()
                air.power_off()
                await asyncio.sleep(30)
                failures = driver.counts["scan_errors"]
                assert failures >= 4
                assert "powered off" in (driver.last_error or "")
                air.power_on()
                await asyncio.sleep(10)
                assert driver.counts["scan_errors"] == failures
                assert driver.status()["last_error"] is None
                assert driver.status()["last_advert_age_s"] < 1
                await driver.close()

        vclock.run(main())

    def test_adapter_refusing_at_start_is_device_unavailable(self) -> None:
        """When the first start fails the device reports DeviceUnavailable with the reason."""
        async def main() -> None:
            air = _air()
            air.fail_next_starts(1)
            driver = BleBeaconScanner([UUID], scanner_factory=air.scanner_factory())
            with pytest.raises(DeviceUnavailable, match=r"InProgress.*bluetoothd"):
                await driver.start()

        vclock.run(main())

    def test_close_tolerates_in_progress_from_bluez(self) -> None:
        """BlueZ answering StopDiscovery with InProgress does not make close() fail."""
        async def main() -> None:
            air = _air()
            driver = BleBeaconScanner([UUID], scanner_factory=air.scanner_factory())
            await driver.start()
            original = air.detach

            def refuse(backend: object) -> None:
                original(backend)  # type: ignore[arg-type]
                raise BleakDBusError("org.bluez.Error.InProgress", ["Operation in progress"])

            air.detach = refuse  # type: ignore[method-assign]
            await driver.close()
            assert driver.status()["scanning"] is False

        vclock.run(main())


class TestScannerFromSettings:
    def test_built_from_the_ble_section(self) -> None:
        """from_settings takes the UUID list and watchdog timings of the ble section."""
        from drivers.ble_scanner import from_settings
        from robotd.config.loader import defaults
        from robotd.config.settings import Settings

        settings = Settings(defaults())
        settings.set("ble.uuids", [UUID.upper()])
        settings.set("ble.stall_timeout_s", 7.0)
        driver = from_settings(settings, scanner_factory=_air().scanner_factory())
        assert driver.stall_timeout_s == 7.0
        assert vclock.run(_uuids(driver)) == [UUID]


async def _uuids(driver: BleBeaconScanner) -> list[str]:
    return list(driver.status()["uuids"])


class TestScannerWatchdogSurvives:
    def test_an_unexpected_error_from_a_restart_does_not_end_the_watchdog(self) -> None:
        """A restart failing with an exception bleak does not document (RuntimeError) is
        counted and reported, and the next restart brings the scan back."""
        async def main() -> None:
            air = _air()
            sim_factory = air.scanner_factory()
            made = 0

            def factory(callback: Any) -> Any:
                nonlocal made
                made += 1
                if made == 2:
                    raise RuntimeError("dbus connection in a bad state")
                return sim_factory(callback)

            driver = BleBeaconScanner([UUID], scanner_factory=factory, stall_timeout_s=2.0)
            seen: list[BeaconSighting] = []
            driver.on_sighting(seen.append)
            async with air.running():
                await driver.start()
                await asyncio.sleep(1)
                air.stall()
                await asyncio.sleep(4)
                assert driver.counts["scan_errors"] == 1
                assert "RuntimeError: dbus connection" in str(driver.status()["last_error"])
                before = len(seen)
                await asyncio.sleep(5)
                assert driver.status()["scanning"] is True and len(seen) > before
                await driver.close()

        vclock.run(main())
