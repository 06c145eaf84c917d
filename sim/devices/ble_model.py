"""The BLE air of the simulated world: iBeacon adverts as a bleak backend delivers them.

``SimBleAir`` is a bleak scanner *backend* (``BaseBleakScanner``), so the real
``bleak.BleakScanner`` and the real driver's detection callback run unchanged; only the radio
is simulated. Each ``SimBeacon`` of the world advertises at its interval (plus BLE's random
0-10 ms advDelay); RSSI follows a log-distance path-loss model from the body's pose with
Gaussian noise, optional loss per wall crossed, dropped adverts and a sensitivity floor.
Fault switches make the "adapter" stall, power off or refuse to start with BlueZ errors.
"""

from __future__ import annotations

import asyncio
import contextlib
import functools
import math
import random
import uuid as uuidlib
from dataclasses import dataclass, field
from typing import Any

from bleak import BleakScanner
from bleak.backends.scanner import (
    AdvertisementData,
    AdvertisementDataCallback,
    BaseBleakScanner,
)
from bleak.exc import (
    BleakBluetoothNotAvailableError,
    BleakBluetoothNotAvailableReason,
    BleakDBusError,
    BleakError,
)

from hal.tasks import cancel_and_wait
from sim.world.body import DiffDriveBody
from sim.world.floor_plan import SimBeacon
from sim.world.geometry import segments_crossed

APPLE_COMPANY_ID = 0x004C
ADV_DELAY_MAX_S = 0.010  # BLE adds a random 0-10 ms to every advertising interval
_new_tuple = tuple.__new__


@dataclass(frozen=True, slots=True)
class BleAirParams:
    path_loss_exponent: float = 2.0
    noise_db: float = 4.0
    drop_prob: float = 0.1
    wall_loss_db: float = 0.0  # per wall between robot and beacon; 0: walls ignored
    sensitivity_dbm: int = -100  # adverts weaker than this are not received
    min_distance_m: float = 0.1


@functools.lru_cache(maxsize=256)  # each beacon sends the same bytes ten times a second
def ibeacon_payload(beacon: SimBeacon) -> bytes:
    """Apple manufacturer data of an iBeacon: 0x02 0x15, UUID, major, minor, power at 1 m."""
    return (bytes((0x02, 0x15)) + uuidlib.UUID(beacon.uuid).bytes
            + beacon.major.to_bytes(2, "big") + beacon.minor.to_bytes(2, "big")
            + beacon.tx_power_dbm.to_bytes(1, "big", signed=True))


class SimScannerBackend(BaseBleakScanner):
    """A bleak backend whose radio is a ``SimBleAir`` (passed as ``BleakScanner(air=...)``)."""

    def __init__(self, detection_callback: AdvertisementDataCallback | None,
                 service_uuids: list[str] | None, scanning_mode: str = "active", *,
                 air: SimBleAir, **kwargs: Any) -> None:
        super().__init__(detection_callback, service_uuids)
        self._air = air

    async def start(self) -> None:
        self.seen_devices = {}
        self._air.attach(self)

    async def stop(self) -> None:
        self._air.detach(self)

    def deliver(self, mac: str, adv: AdvertisementData) -> None:
        device = self.create_or_update_device(mac, mac, None, None, adv)
        self.call_detection_callbacks(device, adv)


@dataclass
class SimBleAir:
    """The radio between the world's beacons and the robot's adapter.

    Args:
        body: whose pose the RSSI is computed from.
        rng: the seeded random source (noise, drops, advert jitter).
    """

    body: DiffDriveBody
    rng: random.Random = field(default_factory=lambda: random.Random(1))
    params: BleAirParams = field(default_factory=BleAirParams)
    counts: dict[str, int] = field(default_factory=lambda: dict.fromkeys(
        ("sent", "dropped", "too_weak", "delivered", "starts", "stops", "start_failures"), 0))
    # Replaced, never changed in place: an advert goes to the scanners listening when it
    # was sent, without a copy per advert.
    _listening: tuple[SimScannerBackend, ...] = ()
    _stalled: list[SimScannerBackend] = field(default_factory=list)
    _muted: set[str] = field(default_factory=set)
    _powered: bool = True
    _start_errors: list[BleakError] = field(default_factory=list)
    _extra: list[tuple[str, AdvertisementData]] = field(default_factory=list)
    # mac -> (the beacon, its manufacturer data bytes): built once per beacon, not per advert
    _payloads: dict[str, tuple[SimBeacon, bytes]] = field(default_factory=dict)

    # --- what the driver is given ------------------------------------------------------------
    def scanner_factory(self) -> Any:
        """A ``ScannerFactory`` for the driver: a real ``BleakScanner`` over this air."""

        def make(callback: AdvertisementDataCallback) -> BleakScanner:
            return BleakScanner(detection_callback=callback, backend=SimScannerBackend, air=self)

        return make

    def attach(self, backend: SimScannerBackend) -> None:
        self.counts["starts"] += 1
        if self._start_errors:
            self.counts["start_failures"] += 1
            raise self._start_errors.pop(0)
        if not self._powered:
            self.counts["start_failures"] += 1
            msg = "Bluetooth adapter is powered off"
            raise BleakBluetoothNotAvailableError(msg, BleakBluetoothNotAvailableReason.POWERED_OFF)
        if backend not in self._listening:
            self._listening = (*self._listening, backend)

    def detach(self, backend: SimScannerBackend) -> None:
        self.counts["stops"] += 1
        if backend in self._listening:
            self._listening = tuple(b for b in self._listening if b is not backend)
        if backend in self._stalled:
            self._stalled.remove(backend)

    # --- fault switches and physics-style handles ------------------------------------------
    def stall(self) -> None:
        """The adapter keeps "scanning" but delivers nothing until the scan is restarted."""
        self._stalled.extend(b for b in self._listening if b not in self._stalled)

    def fail_next_starts(self, count: int = 1, dbus_error: str = "org.bluez.Error.InProgress",
                         detail: str = "Operation already in progress") -> None:
        """The next ``count`` scan starts fail the way BlueZ refuses them."""
        self._start_errors.extend(BleakDBusError(dbus_error, [detail]) for _ in range(count))

    def power_off(self) -> None:
        """rfkill / adapter off: no adverts, and starts fail until ``power_on``."""
        self._powered = False

    def power_on(self) -> None:
        self._powered = True

    def mute(self, mac: str) -> None:
        """A beacon's battery died: it stops advertising."""
        self._muted.add(mac)

    def unmute(self, mac: str) -> None:
        self._muted.discard(mac)

    def inject(self, mac: str, manufacturer_data: dict[int, bytes], rssi_dbm: int = -60) -> None:
        """Deliver one arbitrary advert at the next tick (a phone, a malformed beacon...)."""
        self._extra.append((mac, _advert(manufacturer_data, rssi_dbm)))

    @property
    def scanning(self) -> bool:
        return any(b not in self._stalled for b in self._listening)

    # --- the radio ---------------------------------------------------------------------------
    def rssi_dbm(self, beacon: SimBeacon) -> float:
        """Noise-free mean RSSI at the body's position."""
        p = self.params
        pose = self.body.pose
        distance_m = math.hypot(beacon.x_m - pose.x_m, beacon.y_m - pose.y_m)
        if not distance_m > p.min_distance_m:  # max(min_distance_m, distance_m), without a call
            distance_m = p.min_distance_m
        rssi = beacon.tx_power_dbm - 10 * p.path_loss_exponent * math.log10(distance_m)
        if p.wall_loss_db:
            rssi -= p.wall_loss_db * segments_crossed(self.body.world.walls, pose.x_m,
                                                      pose.y_m, beacon.x_m, beacon.y_m)
        return rssi

    def advertise(self, beacon: SimBeacon) -> None:
        """One advert from ``beacon`` through the air to every listening scanner."""
        p = self.params
        counts = self.counts
        counts["sent"] += 1
        if not self._powered or self.rng.random() < p.drop_prob:
            counts["dropped"] += 1
            return
        rssi = round(self.rssi_dbm(beacon) + self.rng.gauss(0, p.noise_db))
        if rssi < p.sensitivity_dbm:
            counts["too_weak"] += 1
            return
        cached = self._payloads.get(beacon.mac)
        if cached is None or cached[0] is not beacon:
            cached = self._payloads[beacon.mac] = (beacon, ibeacon_payload(beacon))
        self._deliver(beacon.mac, _advert({APPLE_COMPANY_ID: cached[1]},
                                          -127 if rssi < -127 else 20 if rssi > 20 else rssi))

    def _deliver(self, mac: str, adv: AdvertisementData) -> None:
        for backend in self._listening:
            if backend not in self._stalled:
                self.counts["delivered"] += 1
                backend.deliver(mac, adv)

    async def run(self) -> None:
        """Advertise every world beacon at its interval on the loop's clock, until cancelled.

        Each beacon's next advert is a timer whose callback sends it and sets the next one (one
        loop turn per advert; a task sleeping between adverts would cost two). Beacons added to
        the world start within 0.5 s; a removed one stops at its next advert. (Adverts are never
        due at one instant: each interval has its own random advDelay.)
        """
        loop = asyncio.get_running_loop()
        timers: dict[str, asyncio.TimerHandle] = {}
        world = self.body.world
        # The world's beacons as last looked at, and by MAC (the first of a MAC counts): looked
        # at again only when the list changed, not at every advert.
        known: list[SimBeacon] = []
        by_mac: dict[str, SimBeacon] = {}

        def schedule_new() -> None:
            # A beacon lacks a timer only when the list changed: a MAC leaves ``timers`` only
            # once it left the list.
            if world.beacons != known:  # identical objects compare by identity: cheap
                known[:] = world.beacons
                by_mac.clear()
                for beacon in reversed(known):
                    by_mac[beacon.mac] = beacon
                now = loop.time()
                for beacon in known:
                    if beacon.mac not in timers:
                        first_s = now + self.rng.uniform(0, beacon.interval_s)
                        timers[beacon.mac] = loop.call_at(first_s, advert_due, beacon.mac,
                                                          first_s)
            if self._extra:
                self._deliver_extra()

        def advert_due(mac: str, due_s: float) -> None:
            # ``schedule_new`` inlined to its test: it has work only when the list changed.
            if world.beacons != known or self._extra:
                schedule_new()  # ``mac`` is still in ``timers``: only new beacons get a time
            found = by_mac.get(mac)
            if found is None:
                del timers[mac]
                return
            try:
                if mac not in self._muted:
                    self.advertise(found)
            finally:
                # uniform(0, max) is 0 + (max - 0) * random(), its documented formula: the
                # same float without the call (one an advert).
                next_s = due_s + found.interval_s + ADV_DELAY_MAX_S * self.rng.random()
                timers[mac] = loop.call_at(next_s, advert_due, mac, next_s)

        try:
            schedule_new()
            while True:
                await asyncio.sleep(0.5)
                schedule_new()
        finally:
            for timer in timers.values():
                timer.cancel()

    def _deliver_extra(self) -> None:
        while self._extra:
            self._deliver(*self._extra.pop(0))

    @contextlib.asynccontextmanager
    async def running(self) -> Any:
        """``async with air.running():`` advertises in a background task."""
        task = asyncio.create_task(self.run(), name="sim.ble_air")
        try:
            yield self
        finally:
            await cancel_and_wait(task)


def _advert(manufacturer_data: dict[int, bytes], rssi_dbm: int) -> AdvertisementData:
    # (local_name, manufacturer_data, service_data, service_uuids, tx_power, rssi,
    # platform_data) straight to tuple.__new__, as the NamedTuple's generated __new__ does,
    # without its Python frame (one an advert).
    return _new_tuple(AdvertisementData, (None, manufacturer_data, {}, [], None, rssi_dbm, ()))
