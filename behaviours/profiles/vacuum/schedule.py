"""The seed's "청소 예약?" (cleaning scheduled?) in standby: a weekly table of start times.

``vacuum.schedule`` maps a day (``mon`` .. ``sun``, or ``daily``) to start times ``"HH:MM"``
(one string or a list) in the robot's local time (``vacuum.timezone``, else the system's).
``Schedule.next_start(now)`` is the first start after ``now``; standby waits for it (the
seed's "No -> STANDBY" loop is that wait) and then fires ``clean_scheduled``. A bad entry is a
``check-config`` problem on the ``schedule`` line (``schedule_problems``), never a surprise at
run time.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from datetime import datetime, time, timedelta, tzinfo
from typing import Any
from zoneinfo import ZoneInfo, ZoneInfoNotFoundError

from hal.options import ConfigProblem

DAYS = ("mon", "tue", "wed", "thu", "fri", "sat", "sun")
DAILY = "daily"
_TIME = re.compile(r"([01]\d|2[0-3]):([0-5]\d)")


class ScheduleError(ValueError):
    """A schedule entry that cannot be read; says which and why."""


@dataclass(frozen=True, slots=True)
class Schedule:
    """Start times per weekday (0 = Monday), sorted."""

    starts: tuple[tuple[int, time], ...]
    zone: tzinfo | None = None

    @classmethod
    def parse(cls, table: dict[str, Any], zone_name: str = "") -> Schedule:
        """The schedule of a ``vacuum.schedule`` table; ``ScheduleError`` names the entry."""
        starts: set[tuple[int, time]] = set()
        for day, value in table.items():
            if day == DAILY:
                days = range(7)
            elif day in DAYS:
                days = range(DAYS.index(day), DAYS.index(day) + 1)
            else:
                msg = f"{day!r} is not a day (mon, tue, wed, thu, fri, sat, sun or daily)"
                raise ScheduleError(msg)
            times = value if isinstance(value, list) else [value]
            for text in times:
                match = _TIME.fullmatch(text) if isinstance(text, str) else None
                if match is None:
                    msg = f"{day}: expected a time \"HH:MM\" (00:00-23:59), got {text!r}"
                    raise ScheduleError(msg)
                at = time(int(match[1]), int(match[2]))
                starts.update((d, at) for d in days)
        return cls(tuple(sorted(starts)), zone_of(zone_name))

    def next_start(self, now: datetime) -> datetime | None:
        """The first scheduled start strictly after ``now`` (an aware datetime), in the
        schedule's zone; None for an empty schedule."""
        if not self.starts:
            return None
        local = now.astimezone(self.zone)
        for days_ahead in range(8):
            date = (local + timedelta(days=days_ahead)).date()
            for weekday, at in self.starts:
                if weekday != date.weekday():
                    continue
                start = datetime.combine(date, at, tzinfo=local.tzinfo)
                if start > local:
                    return start
        return None  # unreachable: every weekday comes round within 8 days


def zone_of(name: str) -> tzinfo | None:
    """The zone named (IANA), or None for the system's local zone."""
    if not name:
        return None
    try:
        return ZoneInfo(name)
    except (ZoneInfoNotFoundError, ValueError) as exc:
        msg = f"unknown time zone {name!r}"
        raise ScheduleError(msg) from exc


def schedule_problems(values: dict[str, dict[str, Any]], path: str,
                      where: dict[tuple[str, str], int]) -> list[ConfigProblem]:
    """``check-config``: a schedule or time zone the robot could not follow."""
    section = values.get("vacuum", {})
    problems = []
    for key, check in (("timezone", lambda: zone_of(str(section.get("timezone", "")))),
                       ("schedule", lambda: Schedule.parse(dict(section.get("schedule", {}))))):
        try:
            check()
        except ScheduleError as exc:
            problems.append(ConfigProblem(path, where.get(("vacuum", key)), f"vacuum.{key}",
                                          str(exc)))
    return problems
