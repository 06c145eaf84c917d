"""The simulated BLE air: adverts through a real ``BleakScanner`` with path-loss RSSI."""

from __future__ import annotations

import asyncio
import dataclasses
import math
import random
import statistics

from bleak import BleakScanner
from bleak.backends.device import BLEDevice
from bleak.backends.scanner import AdvertisementData
from hypothesis import given
from hypothesis import strategies as st

from sim import vclock
from sim.devices.ble_model import ADV_DELAY_MAX_S, BleAirParams, SimBleAir, _advert
from sim.world.body import DiffDriveBody
from sim.world.floor_plan import World
from sim.world.geometry import Pose

UUID = "fda50693-a4e2-4fb1-afcf-c6eb07647825"


def _air(x_m: float = 3.0, *, params: BleAirParams | None = None, seed: int = 1,
         walls: list[dict[str, float]] | None = None) -> SimBleAir:
    world = World.from_table({"width_m": 10, "height_m": 4, "walls": walls or [], "beacons": [
        {"mac": "C3:00:00:00:01:03", "uuid": UUID, "major": 1, "minor": 103,
         "x_m": 1.0, "y_m": 2.0, "tx_power_dbm": -59, "interval_s": 0.1}]})
    return SimBleAir(DiffDriveBody(world, Pose(x_m, 2.0, 0.0)), rng=random.Random(seed),
                     params=params or BleAirParams())


def _collect(air: SimBleAir, duration_s: float) -> list[tuple[BLEDevice, AdvertisementData]]:
    got: list[tuple[BLEDevice, AdvertisementData]] = []

    async def main() -> None:
        scanner = air.scanner_factory()(lambda d, a: got.append((d, a)))
        assert isinstance(scanner, BleakScanner)
        async with air.running():
            await scanner.start()
            await asyncio.sleep(duration_s)
            await scanner.stop()

    vclock.run(main())
    return got


class TestSimBleAir:
    def test_delivers_real_bleak_objects_with_ibeacon_bytes(self) -> None:
        """Adverts arrive as bleak BLEDevice + AdvertisementData with Apple iBeacon data."""
        device, adv = _collect(_air(), 1.0)[0]
        assert device.address == "C3:00:00:00:01:03"
        data = adv.manufacturer_data[0x004C]
        assert data[:2] == b"\x02\x15" and len(data) == 23
        assert data[2:18].hex() == UUID.replace("-", "")
        assert data[18:22] == bytes((0, 1, 0, 103)) and data[22] == 0xC5  # -59 dBm

    def test_rssi_follows_log_distance_path_loss_with_noise(self) -> None:
        """Mean RSSI at 4 m is tx - 20 log10(4) within 1 dB; spread about the 4 dB noise."""
        rssi = [a.rssi for _, a in _collect(_air(5.0), 30.0)]
        expected = -59 - 20 * math.log10(4.0)
        assert abs(statistics.fmean(rssi) - expected) < 1.0
        assert 3.0 < statistics.pstdev(rssi) < 5.0

    def test_advert_rate_and_drops_follow_the_interval(self) -> None:
        """About 1/(interval + 5 ms) adverts a second are sent, drop_prob of them lost."""
        air = _air(params=BleAirParams(drop_prob=0.25))
        got = _collect(air, 20.0)
        assert 180 <= air.counts["sent"] <= 200
        assert abs(air.counts["dropped"] / air.counts["sent"] - 0.25) < 0.08
        assert len(got) == air.counts["delivered"]

    def test_walls_between_robot_and_beacon_cost_their_loss(self) -> None:
        """With wall_loss_db, one wall in between lowers the mean RSSI by that much."""
        params = BleAirParams(wall_loss_db=6.0, noise_db=0.0, drop_prob=0.0)
        wall = [{"x1": 2.0, "y1": 0.0, "x2": 2.0, "y2": 4.0}]
        clear = _air(params=params).rssi_dbm(_air().body.world.beacons[0])
        behind = _air(params=params, walls=wall)
        assert math.isclose(behind.rssi_dbm(behind.body.world.beacons[0]), clear - 6.0)

    def test_same_seed_same_adverts(self) -> None:
        """A seeded air repeats itself exactly."""
        first = [(a.rssi) for _, a in _collect(_air(seed=3), 3.0)]
        again = [(a.rssi) for _, a in _collect(_air(seed=3), 3.0)]
        assert first == again

    def test_stall_silences_the_scan_until_it_restarts(self) -> None:
        """A stalled adapter delivers nothing to the running scan; a new start clears it."""
        air = _air()
        got: list[int] = []

        async def main() -> None:
            factory = air.scanner_factory()
            scanner = factory(lambda d, a: got.append(a.rssi))
            async with air.running():
                await scanner.start()
                await asyncio.sleep(1)
                air.stall()
                before = len(got)
                await asyncio.sleep(2)
                assert len(got) == before
                await scanner.stop()
                await scanner.start()
                await asyncio.sleep(1)
                assert len(got) > before
                await scanner.stop()

        vclock.run(main())

    def test_muted_beacon_goes_silent(self) -> None:
        """mute(mac) stops that beacon's adverts (a dead battery)."""
        air = _air()
        air.mute("C3:00:00:00:01:03")
        assert _collect(air, 2.0) == []

    def test_injected_adverts_reach_the_real_driver(self) -> None:
        """inject() plays any advert (a phone, a broken beacon) through the same path."""
        from drivers.ble_scanner import BleBeaconScanner

        async def main() -> dict[str, int]:
            air = _air()
            air.mute("C3:00:00:00:01:03")
            driver = BleBeaconScanner([UUID], scanner_factory=air.scanner_factory())
            async with air.running():
                await driver.start()
                air.inject("5A:11:22:33:44:55", {0x004C: bytes.fromhex("1005031c2b8b4f")})
                air.inject("5A:11:22:33:44:56", {0x004C: bytes.fromhex("0215fda50693")})
                await asyncio.sleep(1)
                await driver.close()
            return driver.counts

        counts = vclock.run(main())
        assert (counts["not_ibeacon"], counts["malformed"], counts["sightings"]) == (1, 1, 0)

    def test_beacons_added_removed_and_replaced_while_advertising(self) -> None:
        """A beacon added to the world starts advertising, a removed one stops, one replaced
        by a beacon of the same MAC advertises the new one's bytes from its next advert."""
        air = _air()
        world = air.body.world
        first = world.beacons[0]
        second = dataclasses.replace(first, mac="C3:00:00:00:01:04", minor=104)
        got: list[tuple[float, str, int]] = []

        async def main() -> None:
            loop = asyncio.get_running_loop()
            scanner = air.scanner_factory()(lambda d, a: got.append(
                (loop.time(), d.address, a.manufacturer_data[0x004C][21])))
            async with air.running():
                await scanner.start()
                await asyncio.sleep(1.0)
                world.beacons.append(second)
                await asyncio.sleep(1.0)
                world.beacons.remove(first)
                await asyncio.sleep(1.0)
                world.beacons[0] = dataclasses.replace(second, minor=105)
                await asyncio.sleep(1.0)
                await scanner.stop()

        vclock.run(main())
        first_adverts = [t for t, mac, _ in got if mac == first.mac]
        second_adverts = [(t, minor) for t, mac, minor in got if mac == second.mac]
        assert 1.0 < second_adverts[0][0] < 1.5  # started within the 0.5 s look at the world
        assert first_adverts and max(first_adverts) < 2.2  # gone at its next advert
        assert {m for t, m in second_adverts if t < 3.0} == {104}
        assert {m for t, m in second_adverts if t > 3.2} == {105}


class TestAdvertFastPaths:
    @given(st.floats(-2.0, 12.0), st.floats(-1.0, 5.0), st.floats(0.0, 2.0),
           st.floats(1.0, 4.0), st.integers(-100, 10))
    def test_rssi_is_the_plain_log_distance_formula(self, x_m: float, y_m: float,
                                                    min_distance_m: float, n: float,
                                                    tx_power_dbm: int) -> None:
        """rssi_dbm gives, bit for bit, tx - 10 n log10(max(min distance, distance)), also
        within the minimum distance of the beacon."""
        air = _air(params=BleAirParams(path_loss_exponent=n, min_distance_m=min_distance_m))
        air.body.pose = Pose(x_m, y_m, 0.0)
        beacon = dataclasses.replace(air.body.world.beacons[0], tx_power_dbm=tx_power_dbm)
        d = max(min_distance_m, math.hypot(beacon.x_m - x_m, beacon.y_m - y_m))
        assert air.rssi_dbm(beacon) == beacon.tx_power_dbm - 10 * n * math.log10(d)

    @given(st.integers(-300, 300))
    def test_adverts_are_the_namedtuple_bleak_builds(self, rssi_dbm: int) -> None:
        """An advert is an AdvertisementData equal to one built field by field."""
        data = {0x004C: b"\x02\x15" + bytes(21)}
        adv = _advert(data, rssi_dbm)
        assert type(adv) is AdvertisementData
        assert adv == AdvertisementData(local_name=None, manufacturer_data=data,
                                        service_data={}, service_uuids=[], tx_power=None,
                                        rssi=rssi_dbm, platform_data=())

    @given(st.integers(0, 2**64))
    def test_the_advert_delay_draw_is_uniforms(self, seed: int) -> None:
        """The advDelay drawn as ADV_DELAY_MAX_S * random() is rng.uniform(0, ADV_DELAY_MAX_S)
        of the same generator, float for float."""
        plain, fast = random.Random(seed), random.Random(seed)
        for _ in range(20):
            assert ADV_DELAY_MAX_S * fast.random() == plain.uniform(0, ADV_DELAY_MAX_S)

    def test_rssi_is_clamped_to_what_hci_reports(self) -> None:
        """Adverts carry -127..+20 dBm whatever the model says (a beacon on the antenna, or
        far beyond the floor with no sensitivity floor)."""
        near = _air(params=BleAirParams(noise_db=0.0, drop_prob=0.0, min_distance_m=1e-9))
        near.body.pose = Pose(1.0, 2.0, 0.0)
        far = _air(params=BleAirParams(noise_db=0.0, drop_prob=0.0, sensitivity_dbm=-1000,
                                       path_loss_exponent=40.0))
        assert {a.rssi for _, a in _collect(near, 0.5)} == {20}
        assert {a.rssi for _, a in _collect(far, 0.5)} == {-127}
