"""Short-lived in-process copies of what every data exchange reads but admins rarely change:
the settings, the beacons with their rooms, and each customer's room.

A change made through this process clears them at once; a change made by another server
process on the same database is seen after at most ``ttl_s`` of loop time.
"""

from __future__ import annotations

import asyncio
from dataclasses import dataclass

from sqlalchemy import select
from sqlalchemy.ext.asyncio import AsyncSession

from fleet.db import Database
from fleet.models import Beacon, Customer, Room
from fleet.settings import FleetSettings, load_settings


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


@dataclass(frozen=True)
class SiteView:
    beacons: list[BeaconRow]
    # customer id -> the room of the customer's assigned beacon (None: no beacon)
    customer_rooms: dict[int, int | None]


class SiteCache:
    def __init__(self, ttl_s: float = 2.0) -> None:
        self.ttl_s = ttl_s
        self._settings: tuple[float, FleetSettings] | None = None
        self._site: tuple[float, SiteView] | None = None

    def invalidate(self) -> None:
        self._settings = None
        self._site = None

    def _fresh(self, stamp: float) -> bool:
        return asyncio.get_running_loop().time() - stamp < self.ttl_s

    async def settings(self, db: Database) -> FleetSettings:
        if self._settings is not None and self._fresh(self._settings[0]):
            return self._settings[1]
        async with db.read() as session:
            cfg = await load_settings(session)
        self._settings = (asyncio.get_running_loop().time(), cfg)
        return cfg

    async def site(self, db: Database) -> SiteView:
        if self._site is not None and self._fresh(self._site[0]):
            return self._site[1]
        async with db.read() as session:
            return await self._load_site(session)

    async def _load_site(self, session: AsyncSession) -> SiteView:
        rows = (await session.execute(
            select(Beacon, Room).join(Room, Beacon.room_id == Room.id)
            .where(Beacon.is_active.is_(True)).order_by(Beacon.id)
        )).all()
        beacons = [BeaconRow(b.id, b.mac_address, b.name, b.room_id, r.name, r.floor_color,
                             b.rssi_threshold_dbm, b.is_base) for b, r in rows]
        all_rooms = dict((await session.execute(
            select(Beacon.id, Beacon.room_id))).all())
        customers = (await session.execute(select(Customer.id, Customer.beacon_id))).all()
        view = SiteView(beacons, {
            cid: (all_rooms.get(bid) if bid is not None else None) for cid, bid in customers})
        self._site = (asyncio.get_running_loop().time(), view)
        return view
