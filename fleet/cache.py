"""Short-lived in-process copies of what every data exchange reads but admins rarely change:
the settings, the beacons with their rooms, and each customer's room.

A change made through this process clears them at once; a change made by another server
process on the same database is seen after at most ``ttl_s`` of loop time. One load runs at a
time: callers arriving while it runs wait for it rather than start their own.
"""

from __future__ import annotations

import asyncio
import functools
import json
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from typing import Generic, TypeVar

from sqlalchemy import Connection, select

from fleet.db import Database
from fleet.models import Beacon, Customer, Room
from fleet.settings import FleetSettings, read_settings

T = TypeVar("T")


@dataclass(frozen=True)
class BeaconRow:
    id: int
    mac_address: str
    name: str
    room_id: int
    room_name: str
    floor_color: str | None
    rssi_threshold_dbm: int
    is_base: bool

    def encoded(self, is_target: bool) -> bytes:
        """This beacon as an ``ActiveBeacons`` entry of the data-exchange reply (JSON)."""
        return self._json[is_target]

    @functools.cached_property
    def _json(self) -> tuple[bytes, bytes]:
        def entry(target: bool) -> bytes:
            return json.dumps({
                "MacAddress": self.mac_address, "Name": self.name, "RoomName": self.room_name,
                "RssiThreshold": self.rssi_threshold_dbm, "IsNavigationTarget": target,
            }, separators=(",", ":")).encode()

        return entry(False), entry(True)


@dataclass(frozen=True)
class SiteView:
    beacons: list[BeaconRow]
    # customer id -> the room of the customer's assigned beacon (None: no beacon)
    customer_rooms: dict[int, int | None]
    _encoded: dict[frozenset[int], bytes] = field(default_factory=dict, compare=False,
                                                  repr=False)

    def encoded_beacons(self, target_ids: frozenset[int]) -> bytes:
        """The ``ActiveBeacons`` entries as JSON with these beacons as targets; kept per target
        set (a site has a few: one per customer room, the base, none)."""
        encoded = self._encoded.get(target_ids)
        if encoded is None:
            encoded = b",".join([b.encoded(b.id in target_ids) for b in self.beacons])
            self._encoded[target_ids] = encoded
        return encoded


class Cached(Generic[T]):
    """A value loaded by one caller at a time and kept for ``ttl_s`` of loop time."""

    def __init__(self, load: Callable[[], Awaitable[T]], ttl_s: float) -> None:
        self._load = load
        self._ttl_s = ttl_s
        self._value: tuple[float, int, T] | None = None
        self._epoch = 0
        self._lock = asyncio.Lock()

    def invalidate(self) -> None:
        self._epoch += 1
        self._value = None

    def _fresh(self) -> T | None:
        value = self._value
        if value is None or value[1] != self._epoch:
            return None
        if asyncio.get_running_loop().time() - value[0] >= self._ttl_s:
            return None
        return value[2]

    async def get(self) -> T:
        value = self._fresh()
        if value is not None:
            return value
        async with self._lock:
            value = self._fresh()
            if value is not None:
                return value
            epoch = self._epoch
            loaded = await self._load()
            if epoch == self._epoch:
                self._value = (asyncio.get_running_loop().time(), epoch, loaded)
            return loaded


# The site's queries, built once (a load runs every ``ttl_s`` while robots report).
_ACTIVE_BEACONS = (
    select(Beacon.id, Beacon.mac_address, Beacon.name, Beacon.room_id, Room.name,
           Room.floor_color, Beacon.rssi_threshold_dbm, Beacon.is_base)
    .join(Room, Beacon.room_id == Room.id)
    .where(Beacon.is_active.is_(True)).order_by(Beacon.id))
_BEACON_ROOMS = select(Beacon.id, Beacon.room_id)
_CUSTOMER_BEACONS = select(Customer.id, Customer.beacon_id)


class SiteCache:
    def __init__(self, db: Database, ttl_s: float = 2.0) -> None:
        self._db = db
        self._settings = Cached(self._load_settings, ttl_s)
        self._site = Cached(self._load_site, ttl_s)

    def invalidate(self) -> None:
        self._settings.invalidate()
        self._site.invalidate()

    async def settings(self) -> FleetSettings:
        return await self._settings.get()

    async def site(self) -> SiteView:
        return await self._site.get()

    async def _load_settings(self) -> FleetSettings:
        return await self._db.run_read(read_settings)

    async def _load_site(self) -> SiteView:
        return await self._db.run_read(_read_site)


def _read_site(conn: Connection) -> SiteView:
    beacons = [BeaconRow(*row) for row in conn.execute(_ACTIVE_BEACONS)]
    beacon_rooms = dict(conn.execute(_BEACON_ROOMS).all())
    customers = conn.execute(_CUSTOMER_BEACONS).all()
    return SiteView(beacons, {
        cid: (beacon_rooms.get(bid) if bid is not None else None) for cid, bid in customers})
