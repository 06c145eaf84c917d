"""Navigation targets per request status, sent back in every data exchange (seed section 5)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

from fleet.cache import BeaconRow, SiteView
from fleet.settings import FleetSettings
from fleet.status import HEADS_TO_BASE, HEADS_TO_CUSTOMER, Status


class RequestLike(Protocol):
    """What navigation needs of a request (an ORM row or a light read)."""

    @property
    def status(self) -> str: ...
    @property
    def customer_id(self) -> int: ...
    @property
    def robot_returned(self) -> bool: ...


@dataclass(frozen=True)
class BeaconConfig:
    mac_address: str
    name: str
    room_name: str
    rssi_threshold_dbm: int
    is_navigation_target: bool


@dataclass(frozen=True)
class Navigation:
    site: SiteView
    target_ids: frozenset[int]
    is_line_following: bool
    follow_color: str | None

    @property
    def beacons(self) -> list[BeaconConfig]:
        return [BeaconConfig(b.mac_address, b.name, b.room_name, b.rssi_threshold_dbm,
                             b.id in self.target_ids) for b in self.site.beacons]

    def encoded_beacons(self) -> bytes:
        """The ``ActiveBeacons`` entries as JSON (pre-encoded per site view and target set)."""
        return self.site.encoded_beacons(self.target_ids)


def heads_to_base(request: RequestLike) -> bool:
    if request.status == Status.CANCELLED:
        return not request.robot_returned
    return request.status in HEADS_TO_BASE


def target_beacons(site: SiteView, request: RequestLike | None, *,
                   away: bool = False) -> list[BeaconRow]:
    """Customer-room beacons, base beacons, or none, by the request's status; with no
    request, the base beacons for a robot ``away`` from base (seed flowchart 10, "Send Robot
    to Base": back from a restart, or its request resolved by the staff while it was away)."""
    if request is None:
        return [b for b in site.beacons if b.is_base] if away else []
    if request.status in HEADS_TO_CUSTOMER:
        room_id = site.customer_rooms.get(request.customer_id)
        if room_id is None:
            return []  # the customer has no assigned beacon: no target
        return [b for b in site.beacons if b.room_id == room_id]
    if heads_to_base(request):
        return [b for b in site.beacons if b.is_base]
    return []


def navigation(
    site: SiteView, cfg: FleetSettings, request: RequestLike | None, *, stopped: bool,
    away: bool = False,
) -> Navigation:
    """The beacon configuration, targets and line-following order for a robot.

    Args:
        stopped: the robot is in emergency stop or maintenance mode.
        away: the robot is not known to stand at base.
    """
    targets = target_beacons(site, request, away=away)
    follow_color = targets[0].floor_color if targets and cfg.use_floor_color else None
    return Navigation(site, frozenset(b.id for b in targets),
                      bool(targets) and not stopped, follow_color)
