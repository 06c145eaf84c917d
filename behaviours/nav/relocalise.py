"""Finding itself again: a kidnapped or lost robot relocalises over the whole map.

``Relocaliser.run`` stops the wheels, takes a fresh scan, asks the global search
(``localisation/global_search.py``) where on the map it fits, re-seeds the filter with the best
candidates and turns on the spot: each new view weighs them, until the filter is ``localised``
and has stayed so for ``CONFIRM_RAD`` of turning (one view of a repeating site can fit several
places; a quarter turn more rarely does). No agreement after a full turn: search again from
where it now faces, until ``localisation.relocalise_limit_s``. The search runs in a worker
thread (a few hundred milliseconds on a 1.7 M-cell map): the loop keeps the motor board's
heartbeat and the LiDAR going meanwhile.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import structlog

from behaviours.motion.config import DriveTuning
from behaviours.motion.waypoint_drive import wheel_command
from behaviours.nav.localisation.filter import LIDAR_LOST, LOCALISED, Localiser, OdomPose
from behaviours.nav.localisation.global_search import GlobalSearch
from behaviours.nav.localisation.likelihood_field import select_beams
from hal.devices import Lidar, LinkDown, Motors
from hal.readings import LidarScan, MotorCommand
from hal.settings import SettingsView

log = structlog.get_logger(__name__)

CONFIRM_RAD = math.radians(90)
"""Localised for this much turning (by odometry) before the pose is believed."""
_STEP_S = 0.05
_SCAN_WAIT_S = 2.0
_SCAN_BEAMS = 450
_SCAN_S = 0.15
"""A scan ending this long after the wheels stopped was taken standing (the LD19: 10 Hz)."""


@dataclass(frozen=True, slots=True)
class Relocalisation:
    """How a relocalisation ended."""

    ok: bool
    searches: int
    duration_s: float
    turned_rad: float
    fit_per_beam: float
    """The best lattice score per beam of the last search (higher: the scan fits better)."""
    detail: str = ""


class Relocaliser:
    """Global relocalisation of one robot's filter (see the module's docstring)."""

    def __init__(self, localiser: Localiser, lidar: Lidar, motors: Motors,
                 odometry: Callable[[], OdomPose], settings: SettingsView) -> None:
        self.localiser = localiser
        self.lidar = lidar
        self.motors = motors
        self.odometry = odometry
        self.settings = settings
        self._search: GlobalSearch | None = None
        self._given: Callable[[], bool] = lambda: False
        self.rng = np.random.default_rng(localiser.config.seed + 1)

    @property
    def search(self) -> GlobalSearch:
        """The map's lattice and coarse field, built on first use (a few tens of ms)."""
        if self._search is None:
            self._search = GlobalSearch(self.localiser.grid)
        return self._search

    async def run(self, limit_s: float, given: Callable[[], bool] = lambda: False
                  ) -> Relocalisation:
        """Relocalise within ``limit_s``; ``given()`` true: an operator gave the pose
        meanwhile (``robotctl pose set``), which ends the search as done."""
        loop = asyncio.get_running_loop()
        started = loop.time()
        await self._stop()
        searches, turned, fit = 0, 0.0, -math.inf
        detail = f"not localised within {limit_s:g} s"
        self._given = given
        while loop.time() - started < limit_s:
            if given():
                return Relocalisation(True, searches, loop.time() - started, turned, fit,
                                      "an operator's pose")
            scan = await self._fresh_scan()
            if scan is None or self.localiser.status == LIDAR_LOST:
                detail = "no LiDAR scan to relocalise with"
                break
            beams = select_beams(scan, _SCAN_BEAMS, self.localiser.config.laser_max_range_m)
            poses, fit = await asyncio.to_thread(self.search.candidates, beams, self.rng)
            searches += 1
            if given():
                continue  # the operator's pose stands; the loop's head says so
            self.localiser.start_from(poses)
            self.localiser.mark_uncertain()
            log.info("nav.relocalise_search", search=searches, candidates=poses.shape[0],
                     fit_per_beam=round(fit, 3))
            done, spun = await self._turn_until_localised(started + limit_s)
            turned += spun
            if done:
                return Relocalisation(True, searches, loop.time() - started, turned, fit)
        await self._stop()
        return Relocalisation(False, searches, loop.time() - started, turned, fit, detail)

    async def _turn_until_localised(self, deadline_s: float) -> tuple[bool, float]:
        """Turn on the spot (a full turn at most) until localised for ``CONFIRM_RAD``;
        (confirmed, radians turned)."""
        loop = asyncio.get_running_loop()
        tuning = DriveTuning.from_settings(self.settings)
        command = wheel_command(-tuning.turn_mps, tuning.turn_mps, tuning)
        last = self.odometry()[2]
        turned = 0.0
        since: float | None = None
        try:
            while turned < 2 * math.pi and loop.time() < deadline_s and not self._given():
                with contextlib.suppress(LinkDown):
                    await self.motors.drive(command)
                await asyncio.sleep(_STEP_S)
                heading = self.odometry()[2]
                turned += abs(math.remainder(heading - last, 2 * math.pi))
                last = heading
                if self.localiser.status != LOCALISED:
                    since = None
                elif since is None:
                    since = turned
                elif turned - since >= CONFIRM_RAD:
                    return True, turned
            return False, turned
        finally:
            await self._stop()

    async def _fresh_scan(self) -> LidarScan | None:
        """The first scan that starts after now (the robot standing), or None."""
        loop = asyncio.get_running_loop()
        after = loop.time()
        deadline = after + _SCAN_WAIT_S
        while loop.time() < deadline:
            scan = self.lidar.latest()
            if scan is not None and scan.t_s > after + _SCAN_S:
                return scan
            await asyncio.sleep(_STEP_S)
        return None

    async def _stop(self) -> None:
        with contextlib.suppress(LinkDown):
            await self.motors.drive(MotorCommand.stopped())
