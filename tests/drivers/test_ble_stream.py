"""The BLE scanner on a named pipe of adverts (``ble.source = "stream"``)."""

from __future__ import annotations

import asyncio
import os
import uuid
from pathlib import Path

import pytest
from bleak.backends.scanner import AdvertisementData

from drivers.ble_scanner import from_settings
from drivers.ble_stream import StreamScannerBackend, advert_line, parse_advert
from hal.devices import DeviceUnavailable
from hal.readings import BeaconSighting
from robotd.config.loader import defaults
from robotd.config.settings import Settings

UUID = "E2C56DB5-DFFB-48D2-B060-D0F5A71096E0"
MAC = "C0:FF:EE:00:01:03"


def ibeacon(major: int, minor: int, rssi: int) -> AdvertisementData:
    data = (bytes((0x02, 0x15)) + uuid.UUID(UUID).bytes + major.to_bytes(2, "big")
            + minor.to_bytes(2, "big") + (-59).to_bytes(1, "big", signed=True))
    return AdvertisementData(local_name=None, manufacturer_data={0x004C: data},
                             service_data={}, service_uuids=[], tx_power=None, rssi=rssi,
                             platform_data=())


def stream_settings(pipe: Path | str) -> Settings:
    values = defaults()
    values["ble"].update(source="stream", stream=str(pipe), uuids=[UUID])
    return Settings(values)


class TestAdvertLines:
    def test_a_line_reads_back_as_the_advert_written(self) -> None:
        """advert_line then parse_advert: address, RSSI and manufacturer bytes survive."""
        adv = ibeacon(1, 3, -61)
        parsed = parse_advert(advert_line(MAC, adv).encode())
        assert parsed is not None
        address, back = parsed
        assert address == MAC and back.rssi == -61
        assert back.manufacturer_data == adv.manufacturer_data

    @pytest.mark.parametrize("line", [b"{", b"[]", b'{"address": "x"}',
                                      b'{"address": 5, "rssi": -60}',
                                      b'{"address": "x", "rssi": true}',
                                      b'{"address": "x", "rssi": -60, "manufacturer_data": '
                                      b'{"76": "zz"}}'])
    def test_refuses_what_is_not_an_advert(self, line: bytes) -> None:
        """Bad JSON, a missing or mistyped field, bytes that are not hex: no advert."""
        assert parse_advert(line) is None


class TestStreamScanner:
    def test_the_scanner_reports_an_ibeacon_written_to_the_pipe(self, tmp_path: Path) -> None:
        """The real BleakScanner on the stream backend: an iBeacon line becomes a sighting
        of that beacon; a garbage line in front of it is skipped."""
        pipe = tmp_path / "ble.fifo"
        os.mkfifo(pipe)

        async def main() -> tuple[BeaconSighting, dict[str, object]]:
            scanner = from_settings(stream_settings(pipe))
            seen: asyncio.Queue[BeaconSighting] = asyncio.Queue()
            scanner.on_sighting(seen.put_nowait)
            await scanner.start()
            writer = os.open(pipe, os.O_WRONLY | os.O_NONBLOCK)
            try:
                os.write(writer, b"not an advert\n" + advert_line(MAC, ibeacon(1, 3, -61))
                         .encode())
                sighting = await asyncio.wait_for(seen.get(), 10)
                return sighting, scanner.status()
            finally:
                os.close(writer)
                await scanner.close()

        sighting, status = asyncio.run(main())
        assert sighting.mac == MAC and (sighting.major, sighting.minor) == (1, 3)
        assert sighting.rssi_dbm == -61
        assert status["sightings"] == 1

    def test_a_path_that_is_no_pipe_is_refused_with_the_key(self, tmp_path: Path) -> None:
        """A regular file is not a pipe: DeviceUnavailable naming ble.stream."""
        plain = tmp_path / "adverts.txt"
        plain.write_text("")
        backend = StreamScannerBackend(None, None, path=str(plain))
        with pytest.raises(DeviceUnavailable, match=r"not a named pipe.*ble\.stream"):
            asyncio.run(backend.start())

    def test_stream_without_a_path_is_a_config_error(self) -> None:
        """ble.source = stream needs ble.stream: the error names the key."""
        with pytest.raises(ValueError, match=r"ble\.stream: empty"):
            from_settings(stream_settings(""))
