"""iBeacon scanner on bleak: parses Apple iBeacon adverts and keeps the scan alive.

bleak's ``BleakScanner`` calls our detection callback on the event loop for every advert. We
parse the manufacturer data, filter by proximity UUID and hand ``BeaconSighting`` objects to
the listeners. A watchdog restarts the scan with backoff when the adapter stops delivering
adverts or BlueZ refuses (``org.bluez.Error.InProgress``, adapter powered off).
"""

from __future__ import annotations

import asyncio
import contextlib
import functools
import math
import uuid as uuidlib
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import Any, Protocol

import structlog
from bleak import BleakScanner
from bleak.args.bluez import BlueZScannerArgs
from bleak.backends.device import BLEDevice
from bleak.backends.scanner import AdvertisementData, AdvertisementDataCallback
from bleak.exc import BleakError

from hal.devices import DeviceUnavailable
from hal.readings import BeaconSighting
from hal.settings import SettingsView
from hal.tasks import cancel_and_wait

log = structlog.get_logger(__name__)

APPLE_COMPANY_ID = 0x004C
IBEACON_TYPE = 0x02
IBEACON_LENGTH = 0x15  # 21 bytes follow: UUID 16, major 2, minor 2, measured power 1
IBEACON_PAYLOAD_BYTES = 2 + IBEACON_LENGTH
# HCI reports RSSI in -127..+20 dBm and 127 for "not available"; BlueZ and some adapters hand
# over 0 when they have no RSSI. 0 dBm would put a -59 dBm beacon a millimetre away.
MIN_RSSI_DBM = -127
MAX_RSSI_DBM = 20
FRAME_CACHE_SIZE = 1024


class MalformedAdvert(ValueError):
    """An advert claims to be an iBeacon but its bytes do not fit the layout."""


def valid_rssi_dbm(rssi: object) -> int | None:
    """The advert's RSSI in dBm, or None for the placeholders adapters send without one."""
    if isinstance(rssi, bool) or not isinstance(rssi, int | float) or not math.isfinite(rssi):
        return None
    value = int(rssi)
    if value == 0 or not MIN_RSSI_DBM <= value <= MAX_RSSI_DBM:
        return None
    return value


@dataclass(frozen=True, slots=True)
class IBeaconFrame:
    uuid: str
    major: int
    minor: int
    tx_power_dbm: int


def parse_ibeacon(manufacturer_data: Mapping[int, bytes]) -> IBeaconFrame | None:
    """The iBeacon in an advert's manufacturer data, or None when it carries no iBeacon.

    Raises MalformedAdvert when Apple data starts like an iBeacon (0x02 0x15) but is short.
    """
    if APPLE_COMPANY_ID not in manufacturer_data:
        return None
    # From the adapter, so checked here: the compiled driver (docs/native.md) would refuse a
    # value of another type with a TypeError where the annotation says bytes.
    data: object = manufacturer_data[APPLE_COMPANY_ID]
    if not isinstance(data, bytes | bytearray | memoryview):
        msg = f"Apple manufacturer data: expected bytes, got {type(data).__name__}"
        raise MalformedAdvert(msg)
    if len(data) < 2 or data[0] != IBEACON_TYPE:
        return None  # another Apple format (0x10 Nearby Info, 0x12 Find My, ...)
    if data[1] != IBEACON_LENGTH or len(data) < IBEACON_PAYLOAD_BYTES:
        msg = f"iBeacon payload: expected 23 bytes with length byte 0x15, got {data.hex()}"
        raise MalformedAdvert(msg)
    return _ibeacon_frame(bytes(data))


@functools.lru_cache(maxsize=1024)  # a beacon repeats the same bytes about ten times a second
def _ibeacon_frame(data: bytes) -> IBeaconFrame:
    return IBeaconFrame(
        uuid=str(uuidlib.UUID(bytes=data[2:18])),
        major=int.from_bytes(data[18:20], "big"),
        minor=int.from_bytes(data[20:22], "big"),
        tx_power_dbm=int.from_bytes(data[22:23], "big", signed=True),
    )


# BeaconSighting is a frozen dataclass: its generated __init__ sets each field through
# object.__setattr__ (~0.85 us); its slots' own setters do the same in half of that, and the
# driver makes one an advert. ``new_sighting`` equals the constructor (tests/drivers).
SIGHTING_FIELDS = ("mac", "uuid", "major", "minor", "rssi_dbm", "tx_power_dbm", "t_s")
_new_object = object.__new__
(_set_mac, _set_uuid, _set_major, _set_minor, _set_rssi_dbm, _set_tx_power_dbm,
 _set_t_s) = (getattr(BeaconSighting, name).__set__ for name in SIGHTING_FIELDS)


def new_sighting(mac: str, uuid: str, major: int, minor: int, rssi_dbm: int,
                 tx_power_dbm: int, t_s: float) -> BeaconSighting:
    """``BeaconSighting(mac, uuid, major, minor, rssi_dbm, tx_power_dbm, t_s)``, faster."""
    sighting = _new_object(BeaconSighting)
    _set_mac(sighting, mac)
    _set_uuid(sighting, uuid)
    _set_major(sighting, major)
    _set_minor(sighting, minor)
    _set_rssi_dbm(sighting, rssi_dbm)
    _set_tx_power_dbm(sighting, tx_power_dbm)
    _set_t_s(sighting, t_s)
    return sighting


def build_ibeacon(uuid: str, major: int, minor: int, tx_power_dbm: int) -> bytes:
    """Apple manufacturer data (after the company id) for an iBeacon; inverse of parse."""
    return (bytes((IBEACON_TYPE, IBEACON_LENGTH)) + uuidlib.UUID(uuid).bytes
            + major.to_bytes(2, "big") + minor.to_bytes(2, "big")
            + tx_power_dbm.to_bytes(1, "big", signed=True))


def normalise_uuid(text: str) -> str:
    """Canonical lowercase dashed form; ValueError names the bad text."""
    try:
        return str(uuidlib.UUID(text))
    except ValueError:
        msg = f"not a UUID: {text!r}"
        raise ValueError(msg) from None


class Scanner(Protocol):
    """What we need of ``bleak.BleakScanner``."""

    async def start(self) -> None: ...
    async def stop(self) -> None: ...


ScannerFactory = Callable[[AdvertisementDataCallback], Scanner]


def bleak_scanner_factory(adapter: str = "") -> ScannerFactory:
    """Builds real ``BleakScanner`` objects (BlueZ on Linux) for the given adapter."""

    def make(callback: AdvertisementDataCallback) -> Scanner:
        # BlueZ drops repeated identical adverts unless DuplicateData is set; RSSI smoothing
        # wants every one of them.
        bluez: BlueZScannerArgs = {"filters": {"DuplicateData": True}}
        if adapter:
            bluez["adapter"] = adapter
        return BleakScanner(detection_callback=callback, bluez=bluez)

    return make


def describe_error(exc: BaseException) -> str:
    """One line for logs and status: the D-Bus error name when there is one."""
    dbus_error = getattr(exc, "dbus_error", None)
    if dbus_error:
        return f"{dbus_error}: {exc}"
    return f"{type(exc).__name__}: {exc}"


# What a failing start or stop can raise: bleak's errors, D-Bus socket errors, timeouts.
SCAN_ERRORS = (BleakError, OSError, asyncio.TimeoutError, EOFError)


class BleBeaconScanner:
    """``hal.devices.BeaconScanner`` on bleak, with a watchdog that restarts a dead scan.

    Args:
        uuids: proximity UUIDs to report; empty reports every iBeacon.
        scanner_factory: builds a scanner around our callback; the simulator passes one whose
            ``BleakScanner`` has a simulated backend.
        stall_timeout_s: no advert at all for this long counts as a stalled adapter.
        restart_base_s, restart_max_s: restart backoff, doubling up to the cap.
    """

    def __init__(self, uuids: Iterable[str] = (), *,
                 scanner_factory: ScannerFactory | None = None, name: str = "ble",
                 stall_timeout_s: float = 10.0, restart_base_s: float = 0.5,
                 restart_max_s: float = 30.0, start_timeout_s: float = 10.0) -> None:
        self.name = name
        self._uuids = frozenset(normalise_uuid(u) for u in uuids)
        self._factory = scanner_factory or bleak_scanner_factory()
        self.stall_timeout_s = stall_timeout_s
        self._restart_base_s = restart_base_s
        self._restart_max_s = restart_max_s
        self._start_timeout_s = start_timeout_s
        self._callbacks: tuple[Callable[[BeaconSighting], None], ...] = ()
        # The loop's clock, bound when the scan starts (bleak calls back on that loop); until
        # then looked up at each call, as asyncio.get_running_loop() would.
        self._clock: Callable[[], float] = lambda: asyncio.get_running_loop().time()
        self._scanner: Scanner | None = None
        self._watchdog: asyncio.Task[None] | None = None
        self._last_advert_s = 0.0
        self._backoff_s = restart_base_s
        self._alive_since_restart = True
        self.counts = dict.fromkeys(("adverts", "sightings", "not_ibeacon", "malformed",
                                     "other_uuid", "bad_rssi", "callback_errors", "restarts",
                                     "scan_errors"), 0)
        self.last_error: str | None = None
        self.last_sighting: BeaconSighting | None = None
        # Apple manufacturer data bytes -> the iBeacon in them: a beacon repeats the same
        # bytes ten times a second, so each distinct payload is parsed once.
        self._frames: dict[bytes, IBeaconFrame] = {}

    # --- BeaconScanner ----------------------------------------------------------------------
    def on_sighting(self, callback: Callable[[BeaconSighting], None]) -> None:
        # A new tuple, not an append: an advert being handed out goes on over the old one.
        self._callbacks = (*self._callbacks, callback)

    async def start(self) -> None:
        if self._watchdog is not None:
            return
        try:
            await self._start_scanner()
        except SCAN_ERRORS as exc:
            msg = (f"{self.name}: cannot start the BLE scan ({describe_error(exc)}); check that "
                   "bluetoothd runs and the adapter is powered (bluetoothctl show)")
            raise DeviceUnavailable(msg) from exc
        self._watchdog = asyncio.create_task(self._watch(), name=f"{self.name}.watchdog")

    async def close(self) -> None:
        """Stop scanning and the watchdog; safe to call twice."""
        task, self._watchdog = self._watchdog, None
        await cancel_and_wait(task)
        await self._stop_scanner()

    def status(self) -> dict[str, Any]:
        try:
            age_s: float | None = round(asyncio.get_running_loop().time()
                                        - self._last_advert_s, 3)
        except RuntimeError:
            age_s = None
        return {
            **self.counts,
            "scanning": self._scanner is not None,
            "uuids": sorted(self._uuids),
            "last_advert_age_s": age_s,
            "backoff_s": self._backoff_s,
            "last_error": self.last_error,
        }

    # --- adverts ----------------------------------------------------------------------------
    def _on_advert(self, device: BLEDevice, adv: AdvertisementData) -> None:
        """bleak's detection callback: runs on the event loop, must never raise into bleak."""
        counts = self.counts
        counts["adverts"] += 1
        now = self._clock()
        self._last_advert_s = now
        if not self._alive_since_restart:
            self._alive_since_restart = True
            self._backoff_s = self._restart_base_s
            if self.last_error is not None:  # the status shows a live problem, the log all
                log.info("ble.recovered", after_error=self.last_error)
                self.last_error = None
        try:
            # What the adapter sent may not be what bleak's annotations say (None, NaN, a
            # float RSSI, bytearray data): held as objects, so the compiled driver checks
            # them here instead of raising TypeError (docs/native.md).
            sent: Any = adv  # read as plain objects: no type check on reading a field
            manufacturer_data = sent.manufacturer_data
            data: object = manufacturer_data.get(APPLE_COMPANY_ID) \
                if type(manufacturer_data) is dict else None
            # A payload seen before gives its frame here; ``_parse`` parses and keeps the rest.
            frame = self._frames.get(data) if type(data) is bytes else None
            if frame is None:
                frame = self._parse(manufacturer_data, data)
            if frame is None:
                counts["not_ibeacon"] += 1
                return
            if self._uuids and frame.uuid not in self._uuids:
                counts["other_uuid"] += 1
                return
            rssi: object = sent.rssi
            # The usual advert, an int in range, without valid_rssi_dbm's general checks.
            rssi_dbm = (rssi if type(rssi) is int and MIN_RSSI_DBM <= rssi <= MAX_RSSI_DBM
                        and rssi != 0 else valid_rssi_dbm(rssi))
            if rssi_dbm is None:
                # Tracked as a sighting it would drag the smoothed RSSI up to "arrived".
                counts["bad_rssi"] += 1
                log.debug("ble.bad_rssi", mac=getattr(device, "address", "?"), rssi=rssi)
                return
            sighting = new_sighting(str(device.address).upper(), frame.uuid, frame.major,
                                    frame.minor, rssi_dbm, frame.tx_power_dbm, now)
        except (MalformedAdvert, TypeError, AttributeError, ValueError) as exc:
            counts["malformed"] += 1
            log.debug("ble.malformed", mac=getattr(device, "address", "?"), error=str(exc))
            return
        counts["sightings"] += 1
        self.last_sighting = sighting
        for callback in self._callbacks:  # a tuple: a listener added meanwhile waits
            try:
                callback(sighting)
            except Exception:
                counts["callback_errors"] += 1
                log.exception("ble.callback_failed", mac=sighting.mac)

    def _parse(self, manufacturer_data: Mapping[int, bytes], data: object
               ) -> IBeaconFrame | None:
        """``parse_ibeacon`` of a payload not parsed before (raises what it raises), kept by
        ``data``, its Apple payload, when that is bytes."""
        frame = parse_ibeacon(manufacturer_data)
        if frame is not None and type(data) is bytes:
            if len(self._frames) >= FRAME_CACHE_SIZE:  # a storm of distinct payloads
                self._frames.clear()
            self._frames[data] = frame
        return frame

    # --- scanner lifecycle ------------------------------------------------------------------
    async def _start_scanner(self) -> None:
        self._clock = asyncio.get_running_loop().time
        scanner = self._factory(self._on_advert)
        try:
            await asyncio.wait_for(scanner.start(), self._start_timeout_s)
        except SCAN_ERRORS:
            # A start that timed out may have reached BlueZ; do not leave discovery running.
            with contextlib.suppress(*SCAN_ERRORS):
                await asyncio.wait_for(scanner.stop(), self._start_timeout_s)
            raise
        self._scanner = scanner
        self._last_advert_s = asyncio.get_running_loop().time()
        log.info("ble.scanning", uuids=len(self._uuids))

    async def _stop_scanner(self) -> None:
        scanner, self._scanner = self._scanner, None
        if scanner is None:
            return
        try:
            await asyncio.wait_for(scanner.stop(), self._start_timeout_s)
        except SCAN_ERRORS as exc:
            # BlueZ may answer StopDiscovery with InProgress after the session is gone.
            log.info("ble.stop_failed", error=describe_error(exc))

    async def _watch(self) -> None:
        loop = asyncio.get_running_loop()
        check_s = min(1.0, self.stall_timeout_s / 4)
        while True:
            await asyncio.sleep(check_s)
            silent_s = loop.time() - self._last_advert_s
            if self._scanner is not None and silent_s < self.stall_timeout_s:
                continue
            if self._scanner is not None:
                log.warning("ble.stalled", silent_s=round(silent_s, 1))
            try:
                await self._restart()
            except Exception as exc:  # not one bleak documents: the watchdog must live on
                self.counts["scan_errors"] += 1
                self.last_error = describe_error(exc)
                log.exception("ble.restart_crashed", error=self.last_error)

    async def _restart(self) -> None:
        """Stop, wait the backoff, start again; the backoff grows until adverts flow again."""
        await self._stop_scanner()
        delay_s = self._backoff_s
        self._backoff_s = min(self._restart_max_s, self._backoff_s * 2)
        await asyncio.sleep(delay_s)
        self.counts["restarts"] += 1
        try:
            await self._start_scanner()
        except SCAN_ERRORS as exc:
            self.counts["scan_errors"] += 1
            self.last_error = describe_error(exc)
            log.warning("ble.restart_failed", error=self.last_error, next_try_s=self._backoff_s)
            return
        self._alive_since_restart = False
        log.info("ble.restarted", restarts=self.counts["restarts"], after_s=delay_s)


def from_settings(settings: SettingsView,
                  scanner_factory: ScannerFactory | None = None) -> BleBeaconScanner:
    """The scanner from the ``ble`` section (``robotd.hardware`` calls this)."""
    if scanner_factory is None and settings.get("ble.source") == "stream":
        from drivers.ble_stream import stream_scanner_factory

        if not settings.get("ble.stream"):
            msg = "ble.stream: empty, but ble.source = 'stream' needs a pipe"
            raise ValueError(msg)
        scanner_factory = stream_scanner_factory(settings.get("ble.stream"))
    return BleBeaconScanner(
        settings.get("ble.uuids"),
        scanner_factory=scanner_factory or bleak_scanner_factory(settings.get("ble.adapter")),
        stall_timeout_s=settings.get("ble.stall_timeout_s"),
        restart_max_s=settings.get("ble.restart_max_s"))
