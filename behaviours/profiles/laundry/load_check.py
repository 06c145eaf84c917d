"""Load check with the load cell (seed 000 section 11).

Loaded: weight > ``weight.min_kg`` and < ``weight.max_kg``; overweight: at or above
``max_kg`` (an alert); unloaded: below ``min_kg``. A verdict needs a steady weight: readings
over the last ``stable_s`` seconds that spread no more than ``stable_kg``, so a customer
still dropping clothes in, or the robot jolting, gives "unstable" rather than a wrong answer.
"""

from __future__ import annotations

import asyncio
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum
from typing import Any

import structlog

from hal.devices import DeviceUnavailable, LoadCell
from hal.readings import WeightReading
from hal.settings import SettingsView

log = structlog.get_logger(__name__)


class LoadVerdict(Enum):
    UNSTABLE = "unstable"  # readings still moving, or too few of them
    WAIT_LOAD = "wait_load"  # not above min_kg yet
    LOADED = "loaded"
    OVERWEIGHT = "overweight"
    WAIT_UNLOAD = "wait_unload"  # not below min_kg yet
    UNLOADED = "unloaded"


@dataclass(frozen=True, slots=True)
class WeightStatus:
    kg: float | None
    stable: bool
    spread_kg: float | None


class LoadCheck:
    """Steady weight and the seed's verdicts from a ``LoadCell``.

    Args:
        load_cell: the device; ``run()`` consumes its readings (or feed ``add``).
        min_kg, max_kg: the ``weight`` section's thresholds (tunable, set the attributes).
        stable_s, stable_kg: the steadiness requirement.
        min_readings: fewest readings in the window that can count as steady.
        stale_s: ``run()`` forgets the weight when the load cell gives nothing for this long
            (its reader stopped getting good codes), so no verdict rests on old readings.
    """

    def __init__(self, load_cell: LoadCell | None = None, *, min_kg: float = 0.5,
                 max_kg: float = 10.0, stable_s: float = 1.0, stable_kg: float = 0.05,
                 min_readings: int = 3, stale_s: float = 3.0) -> None:
        if not min_kg < max_kg:
            msg = f"weight.min_kg ({min_kg}) must be below weight.max_kg ({max_kg})"
            raise ValueError(msg)
        self.load_cell = load_cell
        self.min_kg = min_kg
        self.max_kg = max_kg
        self.stable_s = stable_s
        self.stable_kg = stable_kg
        self.min_readings = min_readings
        self.stale_s = stale_s
        self.stale = False
        self._window: deque[WeightReading] = deque()
        self._overweight = False
        self._alert_listeners: list[Callable[[float], None]] = []

    @classmethod
    def from_settings(cls, load_cell: LoadCell | None, settings: SettingsView) -> LoadCheck:
        """Built from the ``weight`` section; tuned thresholds apply at once."""
        keys = ("min_kg", "max_kg", "stable_s", "stable_kg")
        check = cls(load_cell, **{k: settings.get(f"weight.{k}") for k in keys})

        def tuned(dotted: str, value: Any) -> None:
            key = dotted.rpartition(".")[2]
            if key in ("min_kg", "max_kg"):
                # Both from the settings, which keep the pair in order (config ORDERS).
                check.set_thresholds(min_kg=float(settings.get("weight.min_kg")),
                                     max_kg=float(settings.get("weight.max_kg")))
            elif key in keys:
                setattr(check, key, float(value))

        settings.watch("weight", tuned)
        return check

    def set_thresholds(self, *, min_kg: float | None = None, max_kg: float | None = None
                       ) -> bool:
        """Change the thresholds; a pair out of order is not applied (logged) and the
        previous pair stays, so a half-done retune cannot turn every load into a verdict."""
        new_min = self.min_kg if min_kg is None else min_kg
        new_max = self.max_kg if max_kg is None else max_kg
        if not new_min < new_max:
            log.error("load.thresholds_invalid", min_kg=new_min, max_kg=new_max,
                      kept_min_kg=self.min_kg, kept_max_kg=self.max_kg)
            return False
        self.min_kg, self.max_kg = new_min, new_max
        return True

    def on_overweight(self, callback: Callable[[float], None]) -> None:
        """Call ``callback(kg)`` when a steady load reaches ``max_kg`` (once per episode)."""
        self._alert_listeners.append(callback)

    def add(self, reading: WeightReading) -> None:
        if self._window and reading is self._window[-1]:
            return  # ``run`` and ``wait_for`` both saw it
        self._window.append(reading)
        horizon = reading.t_s - self.stable_s
        while len(self._window) > self.min_readings and self._window[0].t_s < horizon:
            self._window.popleft()
        self._check_alert()

    def weight(self) -> WeightStatus:
        """The newest weight, whether it is steady, and the spread over the window."""
        if not self._window:
            return WeightStatus(None, False, None)
        values = [r.kg for r in self._window]
        spread = max(values) - min(values)
        covered_s = self._window[-1].t_s - self._window[0].t_s
        stable = (len(values) >= self.min_readings and spread <= self.stable_kg
                  and covered_s >= self.stable_s * 0.9)
        return WeightStatus(self._window[-1].kg, stable, spread)

    def check_load(self) -> LoadVerdict:
        """At the customer's room before loading (request ``ArrivedAtRoom``)."""
        w = self.weight()
        if w.kg is None or not w.stable:
            return LoadVerdict.UNSTABLE
        if w.kg >= self.max_kg:
            return LoadVerdict.OVERWEIGHT
        if w.kg > self.min_kg:
            return LoadVerdict.LOADED
        return LoadVerdict.WAIT_LOAD

    def check_unload(self) -> LoadVerdict:
        """At the customer's room for delivery (request ``FinishedWashingArrivedAtRoom``)."""
        w = self.weight()
        if w.kg is None or not w.stable:
            return LoadVerdict.UNSTABLE
        return LoadVerdict.UNLOADED if w.kg < self.min_kg else LoadVerdict.WAIT_UNLOAD

    def _check_alert(self) -> None:
        if self._window[-1].kg < self.max_kg and not self._overweight:
            return  # neither an alert nor an episode to end: no need for the spread
        w = self.weight()
        over = w.stable and w.kg is not None and w.kg >= self.max_kg
        if over and not self._overweight:
            assert w.kg is not None
            log.warning("load.overweight", kg=round(w.kg, 2), max_kg=self.max_kg)
            for callback in list(self._alert_listeners):
                callback(w.kg)
        if w.stable:
            self._overweight = over

    async def wait_for(self, *verdicts: LoadVerdict, unload: bool = False) -> LoadVerdict:
        """Wait for readings until ``check_load`` (or ``check_unload``) gives one of these."""
        if self.load_cell is None:
            msg = "LoadCheck.wait_for needs a load cell"
            raise RuntimeError(msg)
        while True:
            verdict = self.check_unload() if unload else self.check_load()
            if verdict in verdicts:
                return verdict
            self.add(await self.load_cell.next_reading())

    async def run(self) -> None:
        """Consume the load cell's readings until cancelled."""
        if self.load_cell is None:
            return
        loop = asyncio.get_running_loop()
        while True:
            try:
                # One timeout moved on by each reading, not one set up and torn down per
                # reading (asyncio.wait_for, in Python 3.11, also ran each wait as a task).
                async with asyncio.timeout(self.stale_s) as silence:
                    while True:
                        reading = await self.load_cell.next_reading()
                        silence.reschedule(loop.time() + self.stale_s)
                        if self.stale:
                            self.stale = False
                            log.info("load.readings_back")
                        self.add(reading)
            except (TimeoutError, DeviceUnavailable) as exc:
                self._forget(exc)
                if isinstance(exc, DeviceUnavailable):
                    await asyncio.sleep(self.stale_s)

    def _forget(self, exc: BaseException) -> None:
        if not self.stale:
            log.warning("load.no_readings", silent_s=self.stale_s,
                        error=str(exc) or type(exc).__name__)
        self.stale = True
        self._window.clear()

    def status(self) -> dict[str, Any]:
        w = self.weight()
        return {"kg": None if w.kg is None else round(w.kg, 3), "stable": w.stable,
                "stale": self.stale,
                "load": self.check_load().value, "unload": self.check_unload().value}
