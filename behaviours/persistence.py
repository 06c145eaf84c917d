"""Mission state that survives a restart, as a profile declares it, and the e-stop latch.

A profile declares one ``MissionRecord`` per thing it must remember (the laundry robot: the
request it serves, what it holds, where it was): a store key, a version and named fields with
JSON-able defaults. ``Persisted`` holds the live values: restored from the store before the
machine leaves ``boot``, and written back as one value (so one transaction) at each change.
``await persisted.durable()`` returns once the change is committed and fsynced; a profile awaits
it before it acts on the change where a crash in between would lose something.

The e-stop latch is written and made durable before an e-stop is acknowledged, and cleared
(durably) only when a person resumes the robot.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from datetime import UTC
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

import structlog

if TYPE_CHECKING:
    from hal.ports import WallClock

log = structlog.get_logger(__name__)

@runtime_checkable
class KeyValueStore(Protocol):
    """Mission state that must survive a restart (JSON-able values by key)."""

    def get(self, key: str, default: Any = None) -> Any: ...
    def put(self, key: str, value: Any) -> None: ...
    def delete(self, key: str) -> None: ...
    async def flush(self) -> None:
        """Return once every put and delete so far is committed and fsynced."""


Migrate = Callable[[int, dict[str, Any]], dict[str, Any] | None]
"""(stored version, stored values) -> values for the current version, or None to forget them."""


@dataclass(frozen=True, slots=True)
class MissionRecord:
    """What a profile must remember across a restart.

    Args:
        key: the store key, prefixed with the profile's name (``laundry.mission``).
        version: bumped when the fields change meaning; older values go through ``migrate``.
        fields: name -> default (JSON-able); the values after a first start or a reset.
        migrate: turns values of an older version into this one's (None: they are forgotten).
    """

    key: str
    version: int
    fields: Mapping[str, Any]
    migrate: Migrate | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        try:
            json.dumps(dict(self.fields))
        except (TypeError, ValueError) as exc:
            msg = f"{self.key}: field defaults are not JSON-able: {exc}"
            raise ValueError(msg) from exc


class Persisted:
    """The live values of a ``MissionRecord``; every change goes to the store at once.

    Args:
        store: the robot's crash-safe store (``ctx.store``).
        record: what to keep.
    """

    def __init__(self, store: KeyValueStore, record: MissionRecord) -> None:
        self.store = store
        self.record = record
        self.restored = False
        self.writes = 0
        self._values: dict[str, Any] = dict(record.fields)
        self._restore()

    def _restore(self) -> None:
        stored = self.store.get(self.record.key)
        if stored is None:
            return
        values = self._readable(stored)
        if values is None:
            return
        unknown = sorted(set(values) - set(self.record.fields))
        if unknown:
            log.warning("persist.unknown_fields", key=self.record.key, fields=unknown)
        for name in self.record.fields:
            if name in values:
                self._values[name] = values[name]
        self.restored = True
        log.info("persist.restored", key=self.record.key, values=self._values)

    def _readable(self, stored: Any) -> dict[str, Any] | None:
        key, version = self.record.key, self.record.version
        if (not isinstance(stored, dict) or not isinstance(stored.get("values"), dict)
                or not isinstance(stored.get("version"), int)):
            log.error("persist.unreadable", key=key, stored=repr(stored)[:200])
            return None
        values: dict[str, Any] = stored["values"]
        if stored["version"] == version:
            return values
        migrated = None
        if self.record.migrate is not None:
            migrated = self.record.migrate(stored["version"], values)
        log.warning("persist.version_changed", key=key, stored_version=stored["version"],
                    version=version, migrated=migrated is not None)
        return migrated

    def __getitem__(self, name: str) -> Any:
        return self._values[name]

    def values(self) -> dict[str, Any]:
        """A copy of every field's value."""
        return dict(self._values)

    def set(self, **changes: Any) -> bool:
        """Change fields; written to the store (one value) when anything changed.

        Raises KeyError for a field the record does not declare, ValueError for a value JSON
        cannot hold (nothing is changed then).
        """
        unknown = sorted(set(changes) - set(self.record.fields))
        if unknown:
            msg = f"{self.record.key}: no such fields {unknown}"
            raise KeyError(msg)
        new = {**self._values, **changes}
        try:
            new = json.loads(json.dumps(new))
        except (TypeError, ValueError) as exc:
            msg = f"{self.record.key}: value is not JSON-able: {exc}"
            raise ValueError(msg) from exc
        if new == self._values:
            return False
        self._values = new
        self.writes += 1
        self.store.put(self.record.key, {"version": self.record.version, "values": new})
        return True

    def reset(self) -> bool:
        """Back to the declared defaults (written like any change)."""
        return self.set(**dict(self.record.fields))

    async def durable(self) -> None:
        """Return once every change so far is committed and fsynced."""
        await self.store.flush()

    async def update(self, **changes: Any) -> bool:
        """``set`` and then ``durable``: the change is on disk when this returns."""
        changed = self.set(**changes)
        if changed:
            await self.durable()
        return changed


LATCH_KEY = "estop.latch"


class EStopLatch:
    """The e-stop as a latch in the store: set before an e-stop is acknowledged, kept across
    crashes and power cuts, cleared only by a resume.

    Args:
        store: the robot's crash-safe store.
        wall_clock: stamps when the latch was set (``at``, ISO 8601 UTC).
    """

    def __init__(self, store: KeyValueStore, wall_clock: WallClock) -> None:
        self.store = store
        self.wall_clock = wall_clock
        self.failures = 0

    @property
    def record(self) -> dict[str, Any] | None:
        """``{"source", "reason", "at", "also"}`` while latched, else None."""
        value = self.store.get(LATCH_KEY)
        return value if isinstance(value, dict) else None

    @property
    def latched(self) -> bool:
        return self.record is not None

    def only_from(self, source: str) -> bool:
        """Latched by ``source`` alone (e.g. the fleet, which may then lift it)."""
        record = self.record
        return record is not None and record.get("source") == source and not record.get("also")

    async def set(self, source: str, reason: str) -> bool:
        """Latch (the first cause is kept; later ones are added to ``also``) and make it
        durable; False (logged, counted) if the store could not write it."""
        record = self.record
        if record is None:
            record = {"source": source, "reason": reason, "at": self._now(), "also": []}
        elif source != record.get("source") and source not in record.get("also", []):
            record = {**record, "also": [*record.get("also", []), source]}
        else:
            return True
        self.store.put(LATCH_KEY, record)
        return await self._durable("set", source=source)

    async def clear(self, by: str) -> bool:
        """Unlatch (a person resumed) and make it durable."""
        if not self.latched:
            return True
        self.store.delete(LATCH_KEY)
        log.info("estop.latch_cleared", by=by)
        return await self._durable("clear", by=by)

    async def _durable(self, what: str, **fields: Any) -> bool:
        try:
            await self.store.flush()
        except Exception as exc:  # a full or failing disk: the robot still stops, and says so
            self.failures += 1
            log.error("estop.latch_not_persisted", what=what, error=repr(exc), **fields)
            return False
        return True

    def _now(self) -> str:
        return self.wall_clock().astimezone(UTC).isoformat()
