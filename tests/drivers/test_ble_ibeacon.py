"""iBeacon manufacturer-data parsing and the scanner's handling of recorded-style adverts."""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
from typing import Any

import pytest
from bleak.backends.device import BLEDevice
from bleak.backends.scanner import AdvertisementData, AdvertisementDataCallback
from hypothesis import given
from hypothesis import strategies as st

from drivers.ble_scanner import (
    FRAME_CACHE_SIZE,
    SIGHTING_FIELDS,
    BleBeaconScanner,
    IBeaconFrame,
    MalformedAdvert,
    build_ibeacon,
    new_sighting,
    parse_ibeacon,
    valid_rssi_dbm,
)
from hal.devices import BeaconScanner
from hal.readings import BeaconSighting
from sim import vclock

ESTIMOTE = "b9407f30-f5f8-466e-aff9-25556b57fe6d"
AIRLOCATE = "e2c56db5-dffb-48d2-b060-d0f5a71096e0"

# As bleak hands them over on a Raspberry Pi (company id -> bytes after it).
ESTIMOTE_12345_54321 = {0x004C: bytes.fromhex("0215b9407f30f5f8466eaff925556b57fe6d3039d431c5")}
AIRLOCATE_1_2 = {0x004C: bytes.fromhex("0215e2c56db5dffb48d2b060d0f5a71096e000010002c5")}
TRUNCATED = {0x004C: bytes.fromhex("0215b9407f30f5f8466e")}
WRONG_LENGTH_BYTE = {0x004C: bytes.fromhex("0214b9407f30f5f8466eaff925556b57fe6d3039d431")}
APPLE_NEARBY_INFO = {0x004C: bytes.fromhex("1005031c2b8b4f")}  # an iPhone nearby
APPLE_FIND_MY = {0x004C: bytes.fromhex("1219" + "00" * 25)}
MICROSOFT_SWIFT_PAIR = {0x0006: bytes.fromhex("0300800000")}
RUUVI_TAG = {0x0499: bytes.fromhex("0512fc5394c37cfffc040c00ac9676000000000000000000")}


class TestParseIBeacon:
    def test_reads_uuid_major_minor_and_signed_power(self) -> None:
        """A real iBeacon layout gives its UUID, big-endian major/minor and signed power."""
        assert parse_ibeacon(ESTIMOTE_12345_54321) == IBeaconFrame(ESTIMOTE, 12345, 54321, -59)

    def test_other_companies_and_other_apple_formats_are_not_ibeacons(self) -> None:
        """Non-Apple data and Apple data of another type (0x10, 0x12) give None."""
        for data in (MICROSOFT_SWIFT_PAIR, RUUVI_TAG, APPLE_NEARBY_INFO, APPLE_FIND_MY, {}):
            assert parse_ibeacon(data) is None

    def test_truncated_ibeacon_is_malformed(self) -> None:
        """0x02 0x15 with too few bytes raises MalformedAdvert showing the bytes."""
        with pytest.raises(MalformedAdvert, match="0215b9407f30"):
            parse_ibeacon(TRUNCATED)

    def test_wrong_length_byte_is_malformed(self) -> None:
        """An iBeacon type byte with a length other than 0x15 is malformed."""
        with pytest.raises(MalformedAdvert):
            parse_ibeacon(WRONG_LENGTH_BYTE)

    @given(st.uuids(), st.integers(0, 65535), st.integers(0, 65535), st.integers(-128, 127))
    def test_build_and_parse_round_trip(self, uuid: Any, major: int, minor: int,
                                        power: int) -> None:
        """Whatever a beacon advertises is read back unchanged."""
        data = {0x004C: build_ibeacon(str(uuid), major, minor, power)}
        assert parse_ibeacon(data) == IBeaconFrame(str(uuid), major, minor, power)

    @given(st.dictionaries(st.integers(0, 0xFFFF), st.binary(max_size=40), max_size=3))
    def test_arbitrary_bytes_never_raise_anything_but_malformed(
            self, data: dict[int, bytes]) -> None:
        """Random manufacturer data parses, returns None or raises MalformedAdvert."""
        with contextlib.suppress(MalformedAdvert):
            parse_ibeacon(data)


class RecordingScanner:
    """Stands in for ``BleakScanner``: keeps the callback so a test can play adverts into it."""

    def __init__(self, callback: AdvertisementDataCallback) -> None:
        self.callback = callback
        self.started = 0
        self.stopped = 0
        self.stop_error: Exception | None = None

    async def start(self) -> None:
        self.started += 1

    async def stop(self) -> None:
        self.stopped += 1
        if self.stop_error is not None:
            raise self.stop_error

    def play(self, mac: str, data: dict[int, Any], rssi: int = -70) -> None:
        adv = AdvertisementData(None, data, {}, [], None, rssi, ())
        self.callback(BLEDevice(mac, None, None), adv)


def _scanner(uuids: tuple[str, ...] = ()) -> tuple[BleBeaconScanner, list[RecordingScanner]]:
    made: list[RecordingScanner] = []

    def factory(callback: AdvertisementDataCallback) -> RecordingScanner:
        made.append(RecordingScanner(callback))
        return made[-1]

    return BleBeaconScanner(uuids, scanner_factory=factory), made


class TestScannerAdverts:
    def test_implements_the_hal_protocol(self) -> None:
        """The driver is a ``hal.devices.BeaconScanner``."""
        assert isinstance(_scanner()[0], BeaconScanner)

    def test_recorded_adverts_are_sorted_into_sightings_and_counted_skips(self) -> None:
        """Only configured-UUID iBeacons become sightings; the rest are counted, none raise."""
        async def main() -> None:
            driver, made = _scanner((ESTIMOTE.upper(),))
            seen: list[BeaconSighting] = []
            driver.on_sighting(seen.append)
            await driver.start()
            await asyncio.sleep(1.5)
            bleak = made[0]
            bleak.play("d4:ca:6e:00:00:01", ESTIMOTE_12345_54321, rssi=-67)
            for data in (AIRLOCATE_1_2, TRUNCATED, WRONG_LENGTH_BYTE, APPLE_NEARBY_INFO,
                         APPLE_FIND_MY, MICROSOFT_SWIFT_PAIR, RUUVI_TAG, {0x004C: None}):
                bleak.play("11:22:33:44:55:66", data)
            await driver.close()
            assert seen == [BeaconSighting("D4:CA:6E:00:00:01", ESTIMOTE, 12345, 54321, -67,
                                           -59, 1.5)]
            c = driver.counts
            assert (c["adverts"], c["sightings"], c["other_uuid"], c["malformed"],
                    c["not_ibeacon"]) == (9, 1, 1, 3, 4)

        vclock.run(main())

    def test_without_uuids_every_ibeacon_is_reported(self) -> None:
        """An empty UUID list reports iBeacons of any UUID."""
        async def main() -> list[str]:
            driver, made = _scanner()
            seen: list[BeaconSighting] = []
            driver.on_sighting(seen.append)
            await driver.start()
            made[0].play("AA:00:00:00:00:01", ESTIMOTE_12345_54321)
            made[0].play("AA:00:00:00:00:02", AIRLOCATE_1_2)
            await driver.close()
            return [s.uuid for s in seen]

        assert vclock.run(main()) == [ESTIMOTE, AIRLOCATE]

    def test_a_failing_listener_does_not_reach_bleak(self) -> None:
        """An exception in one listener is counted; later listeners still run."""
        async def main() -> tuple[int, int]:
            driver, made = _scanner()
            later: list[BeaconSighting] = []

            def broken(_: BeaconSighting) -> None:
                raise RuntimeError("boom")

            driver.on_sighting(broken)
            driver.on_sighting(later.append)
            await driver.start()
            made[0].play("AA:00:00:00:00:01", ESTIMOTE_12345_54321)
            await driver.close()
            return driver.counts["callback_errors"], len(later)

        assert vclock.run(main()) == (1, 1)

    @pytest.mark.parametrize("rssi", [0, 127, 21, -128, None, float("nan")])
    def test_placeholder_rssi_values_are_counted_not_tracked(self, rssi: Any) -> None:
        """RSSI 0 or +127 (adapters without a reading) never becomes a sighting.

        Tracked, a 0 dBm sighting would put the beacon a millimetre away and report arrival.
        """
        async def main() -> tuple[list[int], int]:
            driver, made = _scanner()
            seen: list[BeaconSighting] = []
            driver.on_sighting(seen.append)
            await driver.start()
            made[0].play("AA:00:00:00:00:01", ESTIMOTE_12345_54321, rssi=rssi)
            made[0].play("AA:00:00:00:00:01", ESTIMOTE_12345_54321, rssi=-127)
            made[0].play("AA:00:00:00:00:01", ESTIMOTE_12345_54321, rssi=20)
            await driver.close()
            return [s.rssi_dbm for s in seen], driver.counts["bad_rssi"]

        assert vclock.run(main()) == ([-127, 20], 1)

    def test_a_bad_configured_uuid_is_refused_up_front(self) -> None:
        """A UUID in the configuration that is not a UUID raises ValueError naming it."""
        with pytest.raises(ValueError, match="not-a-uuid"):
            BleBeaconScanner(["not-a-uuid"])


PAYLOADS = [ESTIMOTE_12345_54321, AIRLOCATE_1_2, TRUNCATED, WRONG_LENGTH_BYTE,
            APPLE_NEARBY_INFO, MICROSOFT_SWIFT_PAIR, {0x004C: None},
            {0x004C: bytearray(AIRLOCATE_1_2[0x004C])},
            {0x004C: build_ibeacon(ESTIMOTE, 7, 8, -61)}]
RSSIS = [-70, -127, 20, 0, 21, 127, -128, -65.0, True, None, float("nan")]


def _expected(data: dict[int, Any], rssi: Any) -> tuple[str, tuple[Any, ...] | None]:
    """What one advert must give, straight from parse_ibeacon and valid_rssi_dbm."""
    try:
        frame = parse_ibeacon(data)
    except (MalformedAdvert, TypeError):
        return "malformed", None
    if frame is None:
        return "not_ibeacon", None
    rssi_dbm = valid_rssi_dbm(rssi)
    if rssi_dbm is None:
        return "bad_rssi", None
    return "sighting", (frame.uuid, frame.major, frame.minor, rssi_dbm, frame.tx_power_dbm)


class TestParsedOncePerPayload:
    @given(st.lists(st.tuples(st.integers(0, len(PAYLOADS) - 1),
                              st.integers(0, len(RSSIS) - 1)), max_size=40))
    def test_repeated_payloads_give_what_a_fresh_parse_gives(
            self, adverts: list[tuple[int, int]]) -> None:
        """Whatever order payloads and RSSI values come in, each advert is sorted and its
        sighting built exactly as parse_ibeacon and valid_rssi_dbm say."""
        async def main() -> tuple[list[tuple[Any, ...]], dict[str, int]]:
            driver, made = _scanner()
            seen: list[BeaconSighting] = []
            driver.on_sighting(seen.append)
            await driver.start()
            for p, r in adverts:
                made[0].play("aa:00:00:00:00:01", PAYLOADS[p], rssi=RSSIS[r])
            await driver.close()
            return ([(s.uuid, s.major, s.minor, s.rssi_dbm, s.tx_power_dbm) for s in seen],
                    driver.counts)

        seen, counts = vclock.run(main())
        expected = [_expected(PAYLOADS[p], RSSIS[r]) for p, r in adverts]
        assert seen == [e for kind, e in expected if kind == "sighting"]
        for kind in ("malformed", "not_ibeacon", "bad_rssi"):
            assert counts[kind] == sum(1 for k, _ in expected if k == kind)
        assert counts["sightings"] == len(seen)

    def test_a_storm_of_distinct_payloads_keeps_the_cache_bounded(self) -> None:
        """3000 distinct iBeacons: each reported with its own minor, the cache stays small."""
        async def main() -> tuple[list[int], int]:
            driver, made = _scanner()
            seen: list[BeaconSighting] = []
            driver.on_sighting(seen.append)
            await driver.start()
            for minor in range(3000):
                made[0].play("aa:00:00:00:00:01", {0x004C: build_ibeacon(ESTIMOTE, 1, minor,
                                                                          -59)})
            await driver.close()
            return [s.minor for s in seen], len(driver._frames)

        minors, cached = vclock.run(main())
        assert minors == list(range(3000))
        assert cached <= FRAME_CACHE_SIZE


class TestNewSighting:
    @given(st.text(max_size=20), st.text(max_size=40), st.integers(0, 65535),
           st.integers(0, 65535), st.integers(-127, 20), st.integers(-128, 127),
           st.floats(allow_nan=False))
    def test_equals_the_constructor(self, mac: str, uuid: str, major: int, minor: int,
                                    rssi_dbm: int, tx_power_dbm: int, t_s: float) -> None:
        """new_sighting gives what BeaconSighting(...) gives: equal, same hash and repr,
        still frozen."""
        args = (mac, uuid, major, minor, rssi_dbm, tx_power_dbm, t_s)
        fast, plain = new_sighting(*args), BeaconSighting(*args)
        assert type(fast) is BeaconSighting
        assert (fast, hash(fast), repr(fast)) == (plain, hash(plain), repr(plain))
        with pytest.raises(dataclasses.FrozenInstanceError):
            fast.rssi_dbm = 0  # type: ignore[misc]

    def test_sets_every_field_of_the_dataclass(self) -> None:
        """A field added to BeaconSighting (or a __post_init__) must be added here too."""
        assert tuple(f.name for f in dataclasses.fields(BeaconSighting)) == SIGHTING_FIELDS
        assert not hasattr(BeaconSighting, "__post_init__")

    def test_sightings_carry_the_loop_time_of_their_advert(self) -> None:
        """t_s is the event loop's time when bleak called back, and the MAC is upper case."""
        async def main() -> list[tuple[str, float]]:
            driver, made = _scanner()
            seen: list[BeaconSighting] = []
            driver.on_sighting(seen.append)
            await driver.start()
            for _ in range(3):
                await asyncio.sleep(0.25)
                made[0].play("aa:00:00:00:00:01", ESTIMOTE_12345_54321)
            await driver.close()
            return [(s.mac, s.t_s) for s in seen]

        assert vclock.run(main()) == [("AA:00:00:00:00:01", t) for t in (0.25, 0.5, 0.75)]
