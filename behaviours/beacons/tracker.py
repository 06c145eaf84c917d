"""Beacon tracking (seed 000 section 7): smoothed RSSI, distance, last seen, server config.

Sightings from the scanner update a tracked entry per MAC: the RSSI is smoothed with a
time-constant exponential average (adverts come at uneven rates), the distance follows
``d = 10^((TxPower - RSSI) / (10 n))``, and a beacon silent for ``removal_timeout_s`` is
dropped. The fleet server's ``ActiveBeacons`` (name, room, RSSI threshold, navigation target)
are applied to tracked beacons; ``detected_beacons()`` gives the data-exchange list.
"""

from __future__ import annotations

import asyncio
import math
from collections.abc import Callable, Iterable, Mapping, ValuesView
from dataclasses import dataclass
from typing import Any

import structlog

from hal.devices import BeaconScanner
from hal.readings import BeaconSighting
from hal.settings import SettingsView
from hal.telemetry import NULL_TELEMETRY, Telemetry

log = structlog.get_logger(__name__)


def distance_m(tx_power_dbm: float, rssi_dbm: float, path_loss_exponent: float) -> float:
    """Log-distance path-loss estimate; the seed's formula is n = 2 (inf when off the scale)."""
    try:
        return float(10 ** ((tx_power_dbm - rssi_dbm) / (10 * path_loss_exponent)))
    except OverflowError:
        return math.inf


_SHOW_PERIOD_S = 0.5

@dataclass(frozen=True, slots=True)
class BeaconConfig:
    """One entry of the server's ``ActiveBeacons``."""

    mac: str
    name: str = ""
    room_name: str = ""
    rssi_threshold_dbm: float | None = None
    is_navigation_target: bool = False

    @classmethod
    def from_active_beacon(cls, entry: Mapping[str, Any], where: str = "ActiveBeacons") -> (
            BeaconConfig):
        """Parse one PascalCase ``ActiveBeacons`` entry; ValueError names the bad field."""
        if not isinstance(entry, Mapping):
            msg = f"{where}: expected an object, got {entry!r}"
            raise ValueError(msg)
        mac = entry.get("MacAddress")
        if not isinstance(mac, str) or not mac:
            msg = f"{where}.MacAddress: expected a MAC address string, got {mac!r}"
            raise ValueError(msg)
        threshold = entry.get("RssiThreshold")
        if threshold is not None and (isinstance(threshold, bool)
                                      or not isinstance(threshold, int | float)
                                      or not math.isfinite(threshold)):
            msg = f"{where}.RssiThreshold: expected a number in dBm, got {threshold!r}"
            raise ValueError(msg)
        target = entry.get("IsNavigationTarget", False)
        if not isinstance(target, bool):
            msg = f"{where}.IsNavigationTarget: expected true or false, got {target!r}"
            raise ValueError(msg)
        return cls(mac=mac.upper(), name=str(entry.get("Name") or ""),
                   room_name=str(entry.get("RoomName") or ""),
                   rssi_threshold_dbm=None if threshold is None else float(threshold),
                   is_navigation_target=target)


@dataclass(slots=True)
class TrackedBeacon:
    mac: str
    uuid: str
    major: int
    minor: int
    tx_power_dbm: int
    rssi_dbm: int
    smoothed_rssi_dbm: float
    path_loss_exponent: float  # the tracker's, as of the last sighting or tuning
    first_seen_s: float
    last_seen_s: float
    sightings: int = 1
    config: BeaconConfig | None = None
    label: str = ""  # the live view's name, ``b<major>_<minor>``

    @property
    def distance_m(self) -> float:
        """Estimated from the smoothed RSSI when read: adverts move the RSSI ten times a
        second a beacon, the distance is read once or twice a second."""
        return distance_m(self.tx_power_dbm, self.smoothed_rssi_dbm, self.path_loss_exponent)

    @property
    def is_navigation_target(self) -> bool:
        return self.config is not None and self.config.is_navigation_target


class BeaconTracker:
    """Tracked beacons from a ``BeaconScanner``'s sightings.

    Args:
        scanner: subscribed to at construction; None to feed ``add_sighting`` by hand.
        path_loss_exponent: n of the distance formula (tunable: ``ble.path_loss_exponent``).
        smoothing_s: time constant of the RSSI average; 0 keeps the raw RSSI.
        removal_timeout_s: a beacon not seen for this long is forgotten (the seed's 10 s).
        clock: loop time by default.
    """

    def __init__(self, scanner: BeaconScanner | None = None, *, path_loss_exponent: float = 2.0,
                 smoothing_s: float = 1.0, removal_timeout_s: float = 10.0,
                 clock: Callable[[], float] | None = None) -> None:
        self.path_loss_exponent = 2.0
        self._beacons: dict[str, TrackedBeacon] = {}
        self.set_path_loss_exponent(path_loss_exponent)
        self.smoothing_s = smoothing_s
        self.removal_timeout_s = removal_timeout_s
        self._clock = clock or (lambda: asyncio.get_running_loop().time())
        self._configs: dict[str, BeaconConfig] = {}
        self.removed = 0
        self.telemetry: Telemetry = NULL_TELEMETRY  # the live view: RSSI at 2 Hz
        self._shown_s = -math.inf
        if scanner is not None:
            scanner.on_sighting(self.add_sighting)

    @classmethod
    def from_settings(cls, scanner: BeaconScanner | None, settings: SettingsView) -> (
            BeaconTracker):
        """Built from the ``ble`` section; tuned values apply at once."""
        tracker = cls(scanner, path_loss_exponent=settings.get("ble.path_loss_exponent"),
                      smoothing_s=settings.get("ble.smoothing_s"),
                      removal_timeout_s=settings.get("ble.removal_timeout_s"))

        def tuned(dotted: str, value: Any) -> None:
            key = dotted.rpartition(".")[2]
            if key == "path_loss_exponent":
                tracker.set_path_loss_exponent(float(value))
            elif key in ("smoothing_s", "removal_timeout_s"):
                setattr(tracker, key, float(value))

        settings.watch("ble", tuned)
        return tracker

    def set_path_loss_exponent(self, n: float) -> None:
        if not (n > 0 and math.isfinite(n)):
            msg = f"ble.path_loss_exponent must be a number > 0, got {n}"
            raise ValueError(msg)
        self.path_loss_exponent = n
        for b in self._beacons.values():
            b.path_loss_exponent = n

    def add_sighting(self, s: BeaconSighting) -> None:
        mac = s.mac
        b = self._beacons.get(mac)  # the keys are upper case: a hit means mac already is
        if b is None:
            mac = mac.upper()
            b = self._beacons.get(mac)
        t_s = s.t_s
        if b is None:
            b = TrackedBeacon(mac, s.uuid, s.major, s.minor, s.tx_power_dbm, s.rssi_dbm,
                              float(s.rssi_dbm), self.path_loss_exponent, t_s, t_s,
                              config=self._configs.get(mac), label=f"b{s.major}_{s.minor}")
            self._beacons[mac] = b
            log.info("beacon.found", mac=mac, major=s.major, minor=s.minor, rssi_dbm=s.rssi_dbm)
        else:
            # max(0.0, ...) and max(last, t) below as conditionals: the same values, no calls
            dt_s = t_s - b.last_seen_s
            if not dt_s > 0.0:
                dt_s = 0.0
            weight = 1.0 if self.smoothing_s <= 0 else 1 - math.exp(-dt_s / self.smoothing_s)
            b.smoothed_rssi_dbm += (s.rssi_dbm - b.smoothed_rssi_dbm) * weight
            b.rssi_dbm = s.rssi_dbm
            b.tx_power_dbm = s.tx_power_dbm
            b.path_loss_exponent = self.path_loss_exponent
            if t_s > b.last_seen_s:  # noqa: PLR1730 (no max() call, see above)
                b.last_seen_s = t_s
            b.sightings += 1
        if t_s >= self._shown_s + _SHOW_PERIOD_S and self.telemetry.enabled:
            self._shown_s = t_s
            self._show()

    def _show(self) -> None:
        """The live view's ``beacons``: smoothed RSSI and distance per ``b<major>_<minor>``
        (a plot's path: ``/beacons.rssi_dbm.b1_101``), and the navigation targets."""
        rssi_dbm: dict[str, float] = {}
        distance: dict[str, float] = {}
        targets: list[str] = []
        for b in self.tracked():
            rssi_dbm[b.label] = round(b.smoothed_rssi_dbm, 1)
            distance[b.label] = round(b.distance_m, 2)
            if b.is_navigation_target:
                targets.append(b.label)
        self.telemetry.values("beacons", rssi_dbm=rssi_dbm, distance_m=distance, targets=targets)

    def prune(self, now_s: float | None = None) -> list[str]:
        """Forget beacons silent for longer than the removal timeout; returns their MACs."""
        now = self._clock() if now_s is None else now_s
        stale = [mac for mac, b in self._beacons.items()
                 if now - b.last_seen_s > self.removal_timeout_s]
        for mac in stale:
            b = self._beacons.pop(mac)
            self.removed += 1
            log.info("beacon.lost", mac=mac, silent_s=round(now - b.last_seen_s, 1))
        return stale

    def apply_config(self, configs: Iterable[BeaconConfig]) -> None:
        """Replace the server configuration (the whole ``ActiveBeacons`` list each time)."""
        self._configs = {c.mac.upper(): c for c in configs}
        for mac, b in self._beacons.items():
            b.config = self._configs.get(mac)

    def apply_active_beacons(self, entries: Iterable[Mapping[str, Any]]) -> list[str]:
        """Apply the server's ``ActiveBeacons``; bad entries are skipped and described."""
        configs, problems = [], []
        for i, entry in enumerate(entries):
            try:
                configs.append(BeaconConfig.from_active_beacon(entry, f"ActiveBeacons[{i}]"))
            except ValueError as exc:
                problems.append(str(exc))
                log.warning("beacon.bad_config", problem=str(exc))
        self.apply_config(configs)
        return problems

    def get(self, mac: str) -> TrackedBeacon | None:
        return self._beacons.get(mac.upper())

    def tracked(self) -> list[TrackedBeacon]:
        """Tracked beacons, strongest first."""
        return sorted(self._beacons.values(), key=lambda b: -b.smoothed_rssi_dbm)

    def beacons(self) -> ValuesView[TrackedBeacon]:
        """Tracked beacons in no particular order (``tracked()`` sorts them)."""
        return self._beacons.values()

    def configs(self) -> list[BeaconConfig]:
        return list(self._configs.values())

    def detected_beacons(self) -> list[dict[str, Any]]:
        """The data-exchange ``DetectedBeacons`` list (PascalCase, seed section 8)."""
        return [{"MacAddress": b.mac, "Uuid": b.uuid, "Major": b.major, "Minor": b.minor,
                 "Rssi": round(b.smoothed_rssi_dbm), "Distance": round(b.distance_m, 2)}
                for b in self.tracked()]

    def status(self) -> dict[str, Any]:
        return {"tracked": len(self._beacons), "removed": self.removed,
                "configured": len(self._configs),
                "beacons": {b.mac: {"rssi_dbm": round(b.smoothed_rssi_dbm, 1),
                                    "distance_m": round(b.distance_m, 2),
                                    "target": b.is_navigation_target} for b in self.tracked()}}

    async def run(self, period_s: float = 1.0) -> None:
        """Prune stale beacons every ``period_s`` until cancelled."""
        while True:
            await asyncio.sleep(period_s)
            self.prune()
