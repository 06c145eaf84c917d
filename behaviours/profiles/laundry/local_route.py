"""Directives without a fleet server: a fixed route of rooms from the config.

For trying a robot on its own (``laundry.route = ["103", "base"]`` with ``fleet.url`` empty):
the robot follows the line to each room in turn; at a customer room it waits until a load is
in the bin (``weight`` section) or ``laundry.load_wait_s`` passes, then goes on. The directives
have the same shape as the server's, so the robot behaves the same either way.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Awaitable, Callable
from typing import Any

import structlog

from behaviours.profiles.laundry.directive import Directive
from behaviours.profiles.laundry.load_check import LoadCheck, LoadVerdict

log = structlog.get_logger(__name__)

_LOAD_POLL_S = 0.2


class LocalRoute:
    def __init__(self, route: list[str], beacons: dict[str, Any], base_room: str,
                 load: LoadCheck | None, on_directive: Callable[[Directive], Awaitable[None]],
                 *, follow_color: str | None = None, load_wait_s: float = 300.0,
                 period_s: float = 1.0) -> None:
        self.route = route
        self.beacons = beacons
        self.base_room = base_room
        self.load = load
        self.on_directive = on_directive
        self.follow_color = follow_color
        self.load_wait_s = load_wait_s
        self.period_s = period_s
        self.leg = 0
        self._arrived = asyncio.Event()

    def arrived(self, room: str | None) -> None:
        """The robot reached a room (its arrival detection says so)."""
        if self.leg < len(self.route) and room == self.route[self.leg]:
            self._arrived.set()

    def directive(self) -> Directive:
        if self.leg >= len(self.route):
            return Directive.stand_still()
        room = self.route[self.leg]
        entries = []
        for mac, cfg in self.beacons.items():
            beacon_room = str(cfg.get("room", ""))
            entries.append({"MacAddress": mac, "Name": str(cfg.get("name", beacon_room)),
                            "RoomName": beacon_room,
                            "RssiThreshold": cfg.get("rssi_threshold_dbm"),
                            "IsNavigationTarget": beacon_room == room})
        # As the fleet server does: the line to follow has the target room's floor colour.
        floor = next((str(cfg["floor_color"]) for cfg in self.beacons.values()
                      if cfg.get("room") == room and cfg.get("floor_color")), None)
        return Directive(line_following=not self._arrived.is_set(),
                         follow_color=floor or self.follow_color, active_beacons=tuple(entries))

    async def run(self) -> None:
        while self.leg < len(self.route):
            room = self.route[self.leg]
            self._arrived.clear()
            log.info("route.leg", room=room, leg=self.leg + 1, of=len(self.route))
            while not self._arrived.is_set():
                await self.on_directive(self.directive())
                with contextlib.suppress(TimeoutError):
                    await asyncio.wait_for(self._arrived.wait(), self.period_s)
            await self.on_directive(self.directive())
            if room != self.base_room and self.load is not None:
                verdict = await self._wait_for_load()
                log.info("route.load", room=room, verdict=verdict)
            self.leg += 1
        while True:
            await self.on_directive(self.directive())
            await asyncio.sleep(self.period_s)

    async def _wait_for_load(self) -> str:
        """Until the bin holds a steady load (LoadCheck is fed by the sensing task)."""
        assert self.load is not None
        loop = asyncio.get_running_loop()
        give_up = loop.time() + self.load_wait_s
        while loop.time() < give_up:
            verdict = self.load.check_load()
            if verdict is LoadVerdict.LOADED:
                return str(verdict.value)
            await asyncio.sleep(_LOAD_POLL_S)
        return "timeout"
