"""The queue at base (``mission.queued``): robots on the painted line at base cannot pass.

The first robot back stops at the base beacon (its RSSI threshold: ``mission.at_base``); the
next one back stops behind it, held by its own obstacle guard, short of the beacon. That robot
is at base, queued, not blocked: it goes to ``mission.queued``, says so (``IsInTarget`` and
``Queued`` in its report, and no ``blocked`` fault), and keeps following the line under its
guard, so that when the robot ahead leaves it pulls up to the beacon and arrives (the server
keeps the base beacons its targets while it reports ``Queued``). What makes it queued rather
than stuck on the way: it is heading to base, its guard has held it ``SETTLE_S``, and it hears
a base beacon no more than ``laundry.base_queue_db`` below that beacon's threshold.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from typing import TYPE_CHECKING

import structlog

from behaviours.beacons.tracker import BeaconTracker
from behaviours.motion.obstacle_guard import ObstacleGuard
from behaviours.profiles.laundry.states import LaundryState, LaundryTrigger

if TYPE_CHECKING:
    from behaviours.context import RobotContext

log = structlog.get_logger(__name__)

SETTLE_S = 2.0
"""Held this long before it counts as queued (not a person stepping across the line)."""
CHECK_EVERY_S = 0.5


class BaseQueue:
    def __init__(self, ctx: RobotContext, tracker: BeaconTracker,
                 guard: ObstacleGuard | None,
                 on_queued: Callable[[], None] = lambda: None) -> None:
        self.ctx = ctx
        self.tracker = tracker
        self.guard = guard
        self.on_queued = on_queued
        """Called as it joins the queue (it is at base: what it holds is handed over)."""

    @property
    def queued(self) -> bool:
        """Whether the robot stands (or pulls up) in the queue at base now."""
        return self.ctx.state == LaundryState.QUEUED

    async def run(self) -> None:
        """Watch a robot heading to base: held near it, it joins the queue."""
        while True:
            await asyncio.sleep(CHECK_EVERY_S)
            if self.ctx.state == LaundryState.TO_BASE:
                rssi_dbm = self.held_near_base_dbm()
                if rssi_dbm is not None:
                    log.info("laundry.queued", base_rssi_dbm=round(rssi_dbm, 1))
                    if await self.ctx.trigger(LaundryTrigger.QUEUED):
                        self.on_queued()

    def held_near_base_dbm(self) -> float | None:
        """The base beacon's RSSI if the guard has held the robot ``SETTLE_S`` within
        ``laundry.base_queue_db`` of a base beacon's threshold; None otherwise."""
        guard = self.guard
        if guard is None or guard.blocked_since_s is None:
            return None
        if self.ctx.loop_time_s() - guard.blocked_since_s < SETTLE_S:
            return None
        margin_db = float(self.ctx.settings.get("laundry.base_queue_db"))
        for beacon in self.tracker.tracked():  # strongest first
            config = beacon.config
            if config is None or not config.is_navigation_target \
                    or config.rssi_threshold_dbm is None:
                continue
            if beacon.smoothed_rssi_dbm >= config.rssi_threshold_dbm - margin_db:
                return beacon.smoothed_rssi_dbm
        return None
