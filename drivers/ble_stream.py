"""A bleak scanner backend whose radio is a named pipe of adverts, one JSON object a line.

For ``ble.source = "stream"``: the real ``BleakScanner`` and everything above it (iBeacon
parsing, the stall watchdog, RSSI smoothing, arrival) run on adverts that another program
writes to the pipe ``ble.stream`` (``mkfifo``): a recording of a site survey replayed, or an
adapter that BlueZ does not drive. One advert a line::

    {"address": "C0:FF:EE:00:01:03", "rssi": -61, "manufacturer_data": {"76": "0215e2c5..."},
     "local_name": null, "tx_power": null}

``manufacturer_data`` maps the company id (decimal) to the bytes in hex, as BlueZ gives them.
The pipe is opened for reading and writing, so a writer that comes and goes is no end of
file: silence is what the scanner's stall watchdog already handles. A line that is not such
an object is counted (``bad_lines``) and skipped.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
from pathlib import Path
from typing import Any

import structlog
from bleak import BleakScanner
from bleak.backends.scanner import AdvertisementData, AdvertisementDataCallback, BaseBleakScanner

from drivers.pipe_source import open_line_pipe

log = structlog.get_logger(__name__)

READ_BYTES = 65536
MAX_LINE_BYTES = 4096


def parse_advert(line: bytes) -> tuple[str, AdvertisementData] | None:
    """One JSON line as (address, advert); None when it is not one."""
    try:
        obj = json.loads(line)
        address = obj["address"]
        rssi = obj["rssi"]
        data = {int(k): bytes.fromhex(v) for k, v in obj.get("manufacturer_data", {}).items()}
    except (ValueError, KeyError, TypeError, AttributeError):
        return None
    if not isinstance(address, str) or isinstance(rssi, bool) or not isinstance(rssi, int):
        return None
    name, tx_power = obj.get("local_name"), obj.get("tx_power")
    return address, AdvertisementData(
        local_name=name if isinstance(name, str) else None, manufacturer_data=data,
        service_data={}, service_uuids=[],
        tx_power=tx_power if isinstance(tx_power, int) else None, rssi=rssi, platform_data=())


def advert_line(address: str, adv: AdvertisementData) -> str:
    """The line ``parse_advert`` reads back (what a writer of the pipe sends)."""
    return json.dumps({"address": address, "rssi": adv.rssi,
                       "manufacturer_data": {str(k): v.hex()
                                             for k, v in adv.manufacturer_data.items()},
                       "local_name": adv.local_name, "tx_power": adv.tx_power}) + "\n"


class StreamScannerBackend(BaseBleakScanner):
    """``BleakScanner(backend=StreamScannerBackend, path=...)``: adverts from the pipe."""

    def __init__(self, detection_callback: AdvertisementDataCallback | None,
                 service_uuids: list[str] | None, scanning_mode: str = "active", *,
                 path: str, **kwargs: Any) -> None:
        super().__init__(detection_callback, service_uuids)
        self.path = Path(path)
        self.bad_lines = 0
        self._fd = -1
        self._partial = b""

    async def start(self) -> None:
        fd = open_line_pipe(self.path, "ble", "ble.stream")
        self.seen_devices = {}
        self._fd = fd
        asyncio.get_running_loop().add_reader(self._fd, self._on_readable)

    async def stop(self) -> None:
        fd, self._fd = self._fd, -1
        if fd >= 0:
            with contextlib.suppress(Exception):
                asyncio.get_running_loop().remove_reader(fd)
            os.close(fd)

    def _on_readable(self) -> None:
        try:
            data = os.read(self._fd, READ_BYTES)
        except BlockingIOError:
            return
        lines = (self._partial + data).split(b"\n")
        self._partial = lines.pop()
        if len(self._partial) > MAX_LINE_BYTES:
            self.bad_lines += 1
            self._partial = b""
        for line in lines:
            advert = parse_advert(line) if line.strip() else None
            if advert is None:
                if line.strip():
                    if self.bad_lines == 0:
                        log.warning("ble.bad_line", path=str(self.path), line=line[:80])
                    self.bad_lines += 1
                continue
            address, adv = advert
            device = self.create_or_update_device(address, address, adv.local_name, None, adv)
            self.call_detection_callbacks(device, adv)


def stream_scanner_factory(path: str) -> Any:
    """A ``drivers.ble_scanner.ScannerFactory`` of ``BleakScanner`` objects on the pipe."""

    def make(callback: AdvertisementDataCallback) -> BleakScanner:
        return BleakScanner(detection_callback=callback, backend=StreamScannerBackend,
                            path=path)

    return make
