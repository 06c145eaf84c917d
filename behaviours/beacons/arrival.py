"""Arrival (seed 000 sections 4 and 8): ``IsInTarget`` from navigation-target beacon RSSI.

The seed reports arrival when a navigation-target beacon's RSSI is at or above its threshold.
A bare comparison toggles with every few dB of noise near the threshold, so the decision has
hysteresis: a beacon counts as reached once its smoothed RSSI has stayed at or above
``threshold + enter_margin_db`` for ``enter_hold_s`` of sightings, and stops counting once it
has stayed below ``threshold - exit_margin_db`` for ``exit_hold_s`` (or at once when the beacon
is lost or stops being a target). The exit hold matters for a robot parked near the threshold
distance: there the smoothed RSSI still wanders by about 1 dB, and a 3 dB band alone toggled
IsInTarget every few seconds. The entry hold keeps the first sighting (nothing to smooth it
yet) or one noisy stretch from stopping the robot early: driving past a room's beacon through
4 dB of noise per advert, the bare comparison stopped it up to 2 m early, held 0.5 s never
more than 0.40 m from the beacon (docs/beacons-and-weight.md).
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from typing import Any

import structlog

from behaviours.beacons.tracker import BeaconTracker
from hal.settings import SettingsView

log = structlog.get_logger(__name__)


class Arrival:
    """Decides ``IsInTarget`` from a ``BeaconTracker``.

    Args:
        tracker: the tracked beacons with the server's configuration applied.
        enter_margin_db, exit_margin_db: the hysteresis band around each beacon's threshold.
        enter_hold_s: how long (in sighting time) a beacon must stay at or above the entry
            level before it counts as reached; 0 enters at the first sighting there.
        exit_hold_s: how long (in sighting time) a reached beacon must stay below the exit
            level before it stops counting; 0 leaves at the first sighting below it.
        default_threshold_dbm: for a target beacon whose configuration has no threshold.
    """

    def __init__(self, tracker: BeaconTracker, *, enter_margin_db: float = 0.0,
                 exit_margin_db: float = 3.0, enter_hold_s: float = 0.5,
                 exit_hold_s: float = 2.0, default_threshold_dbm: float = -70.0) -> None:
        self.tracker = tracker
        self.enter_margin_db = enter_margin_db
        self.exit_margin_db = exit_margin_db
        self.enter_hold_s = enter_hold_s
        self.exit_hold_s = exit_hold_s
        self._above_since_s: dict[str, float] = {}
        self._below_since_s: dict[str, float] = {}
        self.default_threshold_dbm = default_threshold_dbm
        self._reached: set[str] = set()
        self._in_target = False
        self._listeners: list[Callable[[bool], None]] = []
        self.changes = 0

    @classmethod
    def from_settings(cls, tracker: BeaconTracker, settings: SettingsView) -> Arrival:
        """Built from the ``ble`` section; tuned margins apply at the next update."""
        keys = ("enter_margin_db", "exit_margin_db", "enter_hold_s", "exit_hold_s")
        arrival = cls(tracker, **{k: settings.get(f"ble.{k}") for k in keys},
                      default_threshold_dbm=settings.get("ble.default_rssi_threshold_dbm"))

        def tuned(dotted: str, value: Any) -> None:
            key = dotted.rpartition(".")[2]
            if key in keys:
                setattr(arrival, key, float(value))
            elif key == "default_rssi_threshold_dbm":
                arrival.default_threshold_dbm = float(value)

        settings.watch("ble", tuned)
        return arrival

    @property
    def is_in_target(self) -> bool:
        return self._in_target

    @property
    def reached(self) -> list[str]:
        """MACs of the target beacons currently counted as reached."""
        return sorted(self._reached)

    def on_change(self, callback: Callable[[bool], None]) -> None:
        self._listeners.append(callback)

    def update(self) -> bool:
        """Re-evaluate from the tracker's current state; returns ``IsInTarget``."""
        reached: set[str] = set()
        above_since: dict[str, float] = {}
        below_since: dict[str, float] = {}
        for b in self.tracker.beacons():  # each beacon on its own: no order needed
            config = b.config
            if config is None or not config.is_navigation_target:
                continue
            threshold = config.rssi_threshold_dbm
            if threshold is None:
                threshold = self.default_threshold_dbm
            rssi = b.smoothed_rssi_dbm
            if b.mac not in self._reached:
                if rssi >= threshold + self.enter_margin_db:
                    since_s = self._above_since_s.get(b.mac, b.last_seen_s)
                    if b.last_seen_s - since_s >= self.enter_hold_s:
                        reached.add(b.mac)
                    else:
                        above_since[b.mac] = since_s
            elif rssi >= threshold - self.exit_margin_db:
                reached.add(b.mac)
            else:
                since_s = self._below_since_s.get(b.mac, b.last_seen_s)
                if b.last_seen_s - since_s < self.exit_hold_s:
                    reached.add(b.mac)
                    below_since[b.mac] = since_s
        self._reached = reached
        self._above_since_s = above_since
        self._below_since_s = below_since
        in_target = bool(reached)
        if in_target != self._in_target:
            self._in_target = in_target
            self.changes += 1
            log.info("arrival.entered" if in_target else "arrival.left",
                     beacons=sorted(reached))
            for callback in list(self._listeners):
                callback(in_target)
        return in_target

    async def run(self, period_s: float = 0.1) -> None:
        """Re-evaluate every ``period_s`` until cancelled.

        Paced exactly as ``while True: await asyncio.sleep(period_s); self.update()`` is (the
        update one loop turn after its timer, the next timer set from there, an exception
        from ``update`` raised here), but with a timer and a ready callback per period
        instead of a sleep's future, the task's wake-up and a coroutine resume: ten times a
        second a robot, that was ~5 us each in the simulator.
        """
        if not period_s > 0:  # 0 would update at every loop turn and never let time move
            msg = f"Arrival.run: period_s must be > 0 s, got {period_s}"
            raise ValueError(msg)
        loop = asyncio.get_running_loop()
        failed: asyncio.Future[None] = loop.create_future()
        pending: asyncio.Handle

        def due() -> None:  # where the sleep's timer set its future
            nonlocal pending
            pending = loop.call_soon(tick)  # where the future woke the task

        def tick() -> None:
            nonlocal pending
            if failed.done():  # cancelled since the timer: a woken task would not update
                return
            try:
                self.update()
            except Exception as exc:
                failed.set_exception(exc)
                return
            pending = loop.call_later(period_s, due)

        pending = loop.call_later(period_s, due)
        try:
            await failed
        finally:
            pending.cancel()

    def status(self) -> dict[str, Any]:
        return {"is_in_target": self._in_target, "reached": self.reached,
                "changes": self.changes}
