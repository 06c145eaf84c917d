"""The site file: rooms, beacons, customers, robots and settings of one site, in TOML.

```toml
map = "depot.yaml"          # optional: the site's map (map_server YAML + PGM), relative to
                            # this file; the console draws robots with a pose on it
[settings]
AutoAccept = true

[[rooms]]
name = "Laundry"
floor_color = "blue"        # optional

[[beacons]]
mac = "C3:00:00:00:00:01"
name = "base-1"
room = "Laundry"
rssi_threshold_dbm = -65    # optional, default -70
base = true                 # optional, default false

[[customers]]
id = 1                      # optional
name = "Alice"
beacon = "C3:00:00:00:00:02"   # her room's beacon; optional
room = "Room 101"              # optional (the beacon's room by default)

[[robots]]
name = "robot-1"
odom_on_map = [2.0, 1.5, 90.0]  # optional: where its odometry frame (a pose on map "odom",
                            # e.g. a vacuum's) lies on the site map: x_m, y_m, theta_deg

[[lines]]                   # rooms on one painted line: one robot at a time travels it
name = "main"
rooms = ["Room 101", "Room 102"]

[[tokens]]                  # for the simulator and tests; a real site issues its tokens with
role = "robot"              # `robotd-fleet token create` (random, shown once)
subject = "robot-1"         # robot name, customer id ("1") or admin name
token = "..."               # at least 24 characters; stored hashed
```
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Any

from pydantic import ValidationError
from sqlalchemy.ext.asyncio import AsyncSession

from fleet import tokens
from fleet.errors import FleetError
from fleet.services import admin, lines
from fleet.settings import store_settings
from fleet.tokens import Role

_KEYS: dict[str, dict[str, type]] = {
    "rooms": {"name": str, "floor_color": str},
    "beacons": {"mac": str, "name": str, "room": str, "rssi_threshold_dbm": int, "base": bool,
                "active": bool},
    "customers": {"id": int, "name": str, "beacon": str, "room": str},
    "robots": {"name": str, "odom_on_map": list},
    "lines": {"name": str, "rooms": list},
    "tokens": {"role": str, "subject": str, "token": str},
}
_MAX_CHARS = {"floor_color": 32, "name": 100, "room": 100}
"""What the database's columns hold (fleet/models.py): a longer value is refused here."""
_REQUIRED: dict[str, set[str]] = {
    "rooms": {"name"}, "beacons": {"mac", "name", "room"}, "customers": {"name"},
    "robots": {"name"}, "lines": {"name", "rooms"}, "tokens": {"role", "subject", "token"},
}


class SiteError(ValueError):
    """A site file that cannot be used; the message names the file and the entry."""


@dataclass
class Site:
    settings: dict[str, Any] = field(default_factory=dict)
    rooms: list[dict[str, Any]] = field(default_factory=list)
    beacons: list[dict[str, Any]] = field(default_factory=list)
    customers: list[dict[str, Any]] = field(default_factory=list)
    robots: list[dict[str, Any]] = field(default_factory=list)
    lines: list[dict[str, Any]] = field(default_factory=list)
    tokens: list[dict[str, Any]] = field(default_factory=list)
    source: str = "<site>"
    map: Path | None = None
    """The site map's YAML file (``map = "..."``), relative paths from the site file's folder."""

    def odom_placements(self) -> dict[str, tuple[float, float, float]]:
        """Each robot's odometry frame on the site map (``odom_on_map``): name -> (x_m, y_m,
        theta_rad)."""
        return {str(r["name"]): (float(r["odom_on_map"][0]), float(r["odom_on_map"][1]),
                                 math.radians(float(r["odom_on_map"][2])))
                for r in self.robots if "odom_on_map" in r}


def parse_site(text: str, source: str = "<site>") -> Site:
    """Check a site document; raises SiteError naming ``source`` and the bad entry."""
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        msg = f"{source}: {exc}"
        raise SiteError(msg) from exc
    site = Site(source=source)
    for key, value in doc.items():
        if key == "settings":
            if not isinstance(value, dict):
                msg = f"{source}: settings: must be a table"
                raise SiteError(msg)
            site.settings = value
        elif key == "map":
            if not isinstance(value, str) or not value.strip():
                msg = f"{source}: map: must be the path of a map YAML file, got {value!r}"
                raise SiteError(msg)
            site.map = Path(value)
        elif key in _KEYS:
            setattr(site, key, _entries(source, key, value))
        else:
            msg = (f"{source}: {key}: unknown section (known: map, settings, "
                   f"{', '.join(_KEYS)})")
            raise SiteError(msg)
    return site


def _entries(source: str, section: str, value: Any) -> list[dict[str, Any]]:
    if not isinstance(value, list):
        msg = f"{source}: {section}: must be an array of tables ([[{section}]])"
        raise SiteError(msg)
    for i, entry in enumerate(value):
        where = f"{source}: {section}[{i}]"
        if not isinstance(entry, dict):
            msg = f"{where}: must be a table"
            raise SiteError(msg)
        for key, item in entry.items():
            want = _KEYS[section].get(key)
            if want is None:
                msg = f"{where}.{key}: unknown key (known: {', '.join(_KEYS[section])})"
                raise SiteError(msg)
            if not isinstance(item, want) or (want is int and isinstance(item, bool)):
                msg = f"{where}.{key}: must be {want.__name__}, got {item!r}"
                raise SiteError(msg)
            limit = _MAX_CHARS.get(key)
            if limit is not None and isinstance(item, str) and len(item) > limit:
                msg = f"{where}.{key}: at most {limit} characters, got {len(item)}"
                raise SiteError(msg)
            if key == "odom_on_map":
                _check_placement(f"{where}.{key}", item)
            elif isinstance(item, list):
                _check_room_names(f"{where}.{key}", item)
        missing = _REQUIRED[section] - entry.keys()
        if missing:
            msg = f"{where}: missing {', '.join(sorted(missing))}"
            raise SiteError(msg)
    return value


def _check_room_names(where: str, rooms: list[Any]) -> None:
    for j, room in enumerate(rooms):
        if not isinstance(room, str) or not 1 <= len(room) <= _MAX_CHARS["room"]:
            msg = (f"{where}[{j}]: must be a room name (1-{_MAX_CHARS['room']} characters), "
                   f"got {room!r}")
            raise SiteError(msg)


def _check_placement(where: str, value: object) -> None:
    if not isinstance(value, list) or len(value) != 3 or not all(
            isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)
            for v in value):
        msg = f"{where}: must be [x_m, y_m, theta_deg] (three numbers), got {value!r}"
        raise SiteError(msg)


def load_site(path: str | Path) -> Site:
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        msg = f"{path}: cannot read: {exc.strerror}"
        raise SiteError(msg) from exc
    site = parse_site(text, str(path))
    if site.map is not None and not site.map.is_absolute():
        site.map = path.parent / site.map
    return site


async def apply_site(session: AsyncSession, now: datetime, site: Site) -> None:
    """Create or update everything the site names (existing rows stay)."""
    try:
        if site.settings:
            await store_settings(session, site.settings)
        for room in site.rooms:
            await admin.put_room(session, room["name"], room.get("floor_color"))
        for b in site.beacons:
            await admin.put_beacon(
                session, mac=b["mac"], name=b["name"], room=b["room"],
                rssi_threshold_dbm=b.get("rssi_threshold_dbm", -70),
                is_base=b.get("base", False), is_active=b.get("active", True))
        for c in site.customers:
            await admin.put_customer(session, name=c["name"], room=c.get("room"),
                                     beacon=c.get("beacon"), customer_id=c.get("id"))
        for r in site.robots:
            await admin.add_robot(session, now, r["name"], exist_ok=True)
        for i, line in enumerate(site.lines):
            try:
                rooms = [(await admin.room_by_name(session, room)).id
                         for room in line["rooms"]]
            except FleetError as exc:
                msg = f"{site.source}: lines[{i}].rooms: {exc.message}"
                raise SiteError(msg) from exc
            await lines.put_line(session, line["name"], rooms)
        for i, t in enumerate(site.tokens):
            if t["role"] not in set(Role):
                msg = (f"{site.source}: tokens[{i}].role: must be one of "
                       f"{', '.join(Role)}, got {t['role']!r}")
                raise SiteError(msg)
            try:
                await tokens.create(session, now, Role(t["role"]), t["subject"], t["token"])
            except FleetError as exc:
                msg = f"{site.source}: tokens[{i}]: {exc.message}"
                raise SiteError(msg) from exc
    except ValidationError as exc:
        msg = f"{site.source}: settings: {exc.errors()[0]['msg']}"
        raise SiteError(msg) from exc
    except FleetError as exc:
        msg = f"{site.source}: {exc.message}"
        raise SiteError(msg) from exc
