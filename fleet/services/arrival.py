"""What a robot's IsInTarget report means for its request (seed section 4)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from datetime import datetime

import structlog
from sqlalchemy.ext.asyncio import AsyncSession

from fleet.cache import BeaconRow, SiteView
from fleet.models import Robot
from fleet.services import unload
from fleet.services.alerts import LAUNDRY_KINDS, STUCK, close_alerts, open_alerts
from fleet.services.assignment import process_queue
from fleet.services.common import current_request, join_base_queue, release, set_status
from fleet.services.navigation import target_beacons
from fleet.services.notify import notify
from fleet.settings import FleetSettings
from fleet.status import DIRTY_ABOARD, HOLDS_LAUNDRY, Disposition, Status

log = structlog.get_logger(__name__)


@dataclass(frozen=True)
class Sighting:
    """One beacon the robot heard."""

    mac_address: str
    rssi_dbm: int


def reached(targets: Sequence[BeaconRow], sightings: Sequence[Sighting],
            margin_db: float = 0.0) -> bool:
    """A target beacon heard at or above its RSSI threshold (less ``margin_db``)."""
    by_mac = {b.mac_address.upper(): b for b in targets}
    for seen in sightings:
        beacon = by_mac.get(seen.mac_address.upper())
        if beacon is not None and seen.rssi_dbm >= beacon.rssi_threshold_dbm - margin_db:
            return True
    return False


def base_heard(site: SiteView, sightings: Sequence[Sighting], margin_db: float) -> bool:
    """A base beacon heard at its threshold less ``margin_db`` (at base, or queued there)."""
    return reached([b for b in site.beacons if b.is_base], sightings, margin_db)


async def handle_arrival(
    session: AsyncSession, now: datetime, robot: Robot, sightings: Sequence[Sighting],
    site: SiteView, cfg: FleetSettings,
) -> str:
    """Apply an IsInTarget=true report; returns what happened (for logs and tests)."""
    request = await current_request(session, robot)
    if request is None:
        return await _back_at_base(session, now, robot, sightings, site, cfg)
    status = Status(request.status)
    if status in (Status.ACCEPTED, Status.GOING_TO_ROOM):
        # A robot that names the beacons it hears must hear a target; one that names none is
        # trusted, as in the seed.
        targets = target_beacons(site, request)
        if sightings and not reached(targets, sightings):
            return "still-travelling"
        arrived = (Status.ARRIVED_AT_ROOM if status == Status.ACCEPTED
                   else Status.ARRIVED_FOR_DELIVERY)
        set_status(request, arrived, now)
        what = "load" if arrived == Status.ARRIVED_AT_ROOM else "take out"
        notify(session, now, recipient="customer", kind="robot.arrived", request=request,
               robot_name=robot.name,
               message=f"Robot {robot.name} is at your room: please {what} your laundry.")
        return str(arrived)
    if status not in (Status.LAUNDRY_LOADED, Status.GOING_TO_BASE, Status.CANCELLED):
        return "ignored"
    # At base: at the base beacon, or queued behind the robots there (BaseQueueMarginDb).
    if not reached(target_beacons(site, request), sightings, cfg.base_queue_margin_db):
        return "not-at-base"
    if status in (Status.LAUNDRY_LOADED, Status.GOING_TO_BASE):
        await close_alerts(session, now, kinds=[STUCK], request_id=request.id,
                           resolution="ReachedBase", by=robot.name)
        request.admin_alert = None
    if status == Status.CANCELLED and request.disposition == Disposition.ON_ROBOT:
        request.robot_returned = True
        if await open_alerts(session, kinds=LAUNDRY_KINDS, request_id=request.id):
            # The staff cancelled while it was away with the laundry; it keeps the request
            # (and the laundry) until they resolve the alert and say where the laundry is.
            log.info("fleet.robot.at_base_holding", robot=robot.name, request_id=request.id)
            return "at-base-holding"
        request.disposition = (Disposition.DIRTY_AT_BASE
                               if request.cancelled_from in DIRTY_ABOARD
                               else Disposition.HELD_AT_BASE)
    if status == Status.LAUNDRY_LOADED:
        set_status(request, Status.WASHING, now)
        notify(session, now, recipient="admin", kind="laundry.at_base", request=request,
               robot_name=robot.name, message=f"Laundry of request {request.id} is at base.")
    elif status == Status.GOING_TO_BASE:
        set_status(request, Status.COMPLETED, now)
        notify(session, now, recipient="customer", kind="request.completed", request=request,
               message=("Your laundry was delivered." if request.is_paid
                        else "Your laundry was delivered; please pay."))
    else:
        request.robot_returned = True
        if request.cancelled_from in (Status.GOING_TO_ROOM, Status.ARRIVED_FOR_DELIVERY):
            request.disposition = Disposition.HELD_AT_BASE
            notify(session, now, recipient="admin", kind="laundry.held_at_base",
                   request=request, robot_name=robot.name,
                   message=f"Clean laundry of cancelled request {request.id} is held at base.")
    release(robot)
    if robot.has_left_base or robot.base_place is None:
        await join_base_queue(session, robot)
    else:  # sent back before it left the base: it stands where it stood
        log.info("fleet.robot.kept_place", robot=robot.name, place=robot.base_place)
    unload.hold(robot, now, cfg, laundry_aboard=status == Status.LAUNDRY_LOADED or (
        status == Status.CANCELLED and request.cancelled_from in HOLDS_LAUNDRY))
    await process_queue(session, now, cfg)
    log.info("fleet.robot.at_base", robot=robot.name, request_id=request.id,
             status=request.status)
    return "at-base"


async def _back_at_base(session: AsyncSession, now: datetime, robot: Robot,
                        sightings: Sequence[Sighting], site: SiteView,
                        cfg: FleetSettings) -> str:
    """A robot with no request, sent to base (it was away), reports that it is there: it
    joins the back of the base queue, and may be sent out again."""
    if robot.base_place is not None:
        return "ignored"
    if sightings and not reached(target_beacons(site, None, away=True), sightings,
                                 cfg.base_queue_margin_db):
        return "not-at-base"
    await join_base_queue(session, robot)
    robot.is_in_target = False
    unload.hold(robot, now, cfg, laundry_aboard=False)
    log.info("fleet.robot.back_at_base", robot=robot.name)
    await process_queue(session, now, cfg)
    return "at-base"
