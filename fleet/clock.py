"""The injected wall clock of the fleet server, and how timestamps are stored."""

from __future__ import annotations

from collections.abc import Callable
from datetime import UTC, datetime, timedelta
from typing import Any

from sqlalchemy import DateTime
from sqlalchemy.engine import Dialect
from sqlalchemy.types import TypeDecorator

Clock = Callable[[], datetime]
"""Returns the current time as an aware UTC datetime."""


def system_clock() -> datetime:
    return datetime.now(UTC)


def loop_clock(origin: datetime, loop_time: Callable[[], float]) -> Clock:
    """A clock that follows an event loop's time (virtual time in the simulator).

    Args:
        origin: the wall-clock time that loop time 0 stands for.
        loop_time: usually ``asyncio.get_running_loop().time``.
    """
    start = origin.astimezone(UTC)

    def now() -> datetime:
        return start + timedelta(seconds=loop_time())

    return now


class UtcDateTime(TypeDecorator[datetime]):
    """Stores aware datetimes as naive UTC (same on SQLite and PostgreSQL); returns aware UTC."""

    impl = DateTime(timezone=False)
    cache_ok = True

    def process_bind_param(self, value: datetime | None, dialect: Dialect) -> datetime | None:
        if value is None:
            return None
        if value.tzinfo is None:
            msg = "naive datetime given; the fleet server stores UTC only"
            raise ValueError(msg)
        return value.astimezone(UTC).replace(tzinfo=None)

    def process_result_value(self, value: Any, dialect: Dialect) -> datetime | None:
        if value is None:
            return None
        assert isinstance(value, datetime)
        return value.replace(tzinfo=UTC)
