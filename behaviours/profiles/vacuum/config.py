"""The vacuum profile's own config section, ``vacuum`` (cleaning, battery check, schedule),
each key declared once as a ``VacuumConfig`` field."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from hal.options import load, section_of, setting
from hal.settings import SettingsView


@dataclass(frozen=True, slots=True)
class VacuumConfig:
    """The ``vacuum`` section."""

    clean_mps: float = setting(0.2, "Speed while cleaning.", min=0.02, max=1.0, tunable=True)
    battery_check_s: float = setting(
        10.0, "The seed's periodic battery check while cleaning, every this long.",
        min=0.5, max=3600, tunable=True)
    battery_stale_s: float = setting(
        30.0, "A battery reading older than this (or none at all) cannot be read: the check "
        "reports a fault (battery_unreadable) rather than cleaning on.", min=1, max=3600,
        tunable=True)
    wall_follow_s: float = setting(
        15.0, "Follow a wall met on the right this long before bouncing on again.",
        min=0, max=3600, tunable=True)
    schedule: dict[str, Any] = setting(
        {}, "The seed's 'cleaning scheduled?' in standby: a weekly table, day -> start times "
        "in the robot's local time, e.g. { mon = [\"09:00\"], thu = [\"09:00\", \"14:30\"] } "
        "(days mon..sun, or daily); empty: only standby_s starts a clean.")
    timezone: str = setting(
        "", "The schedule's time zone (an IANA name such as Europe/Berlin); '': the system's.")
    standby_s: float = setting(
        0.0, "In standby on the dock, also start the next clean after this long (0: only the "
        "schedule does; for demonstrations and tests).", min=0, max=604800, tunable=True)
    autostart: bool = setting(True, "Start cleaning once booted.")

    @classmethod
    def from_settings(cls, settings: SettingsView) -> VacuumConfig:
        return load(cls, settings.section(VACUUM.name))


VACUUM = section_of(VacuumConfig, "vacuum",
                    "The robot vacuum (seed ir-docking-flowcharts.md): cleaning and its schedule.")
