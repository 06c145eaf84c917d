"""Site-wide fleet settings (`PUT /api/settings`), kept in the database so every server process
of a site sees the same values."""

from __future__ import annotations

import functools
import json
from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, Field, StringConstraints, model_validator
from sqlalchemy import Connection, select
from sqlalchemy.ext.asyncio import AsyncConnection, AsyncSession

from fleet.db import SITE, announce
from fleet.models import Setting

WebhookUrl = Annotated[str, StringConstraints(max_length=500, pattern=r"^https?://[^\s]+$")]
"""An http:// or https:// URL."""


class FleetSettings(BaseModel):
    """Every tunable of the server, with the seed's behaviour as default."""

    model_config = ConfigDict(populate_by_name=True, extra="forbid", frozen=True)

    auto_accept: bool = Field(True, alias="AutoAccept")
    # Seed section 3: with no available robot, name the least recently assigned busy one for
    # the new request (never resetting its request: fleet.services.assignment).
    preempt_busy_robot: bool = Field(False, alias="PreemptBusyRobot")
    accepted_timeout_s: float = Field(600.0, alias="AcceptedTimeoutS", gt=0, le=86400)
    arrived_timeout_s: float = Field(300.0, alias="ArrivedTimeoutS", gt=0, le=86400)
    delivery_arrived_timeout_s: float = Field(
        300.0, alias="DeliveryArrivedTimeoutS", gt=0, le=86400)
    # A robot holding laundry that does not reach base raises an alert (not a cancellation).
    laundry_loaded_timeout_s: float = Field(600.0, alias="LaundryLoadedTimeoutS", gt=0,
                                            le=86400)
    going_to_base_timeout_s: float = Field(600.0, alias="GoingToBaseTimeoutS", gt=0, le=86400)
    timeout_check_period_s: float = Field(10.0, alias="TimeoutCheckPeriodS", gt=0, le=3600)
    offline_after_s: float = Field(30.0, alias="OfflineAfterS", gt=0, le=86400)
    offline_check_period_s: float = Field(30.0, alias="OfflineCheckPeriodS", gt=0, le=3600)
    min_weight_kg: float = Field(0.5, alias="MinWeightKg", ge=0, le=1000)
    max_weight_kg: float = Field(10.0, alias="MaxWeightKg", gt=0, le=1000)
    require_weight_check: bool = Field(True, alias="RequireWeightCheck")
    # A robot back at base with a load is dispatched again once its load cell has read below
    # MinWeightKg this long (or the staff say it is unloaded).
    unload_settled_s: float = Field(5.0, alias="UnloadSettledS", ge=0, le=3600)
    # A robot heading to base that stops behind the robots queued there reports IsInTarget
    # while it hears a base beacon at most this far below its threshold: it is at base.
    base_queue_margin_db: float = Field(10.0, alias="BaseQueueMarginDb", ge=0, le=60)
    use_floor_color: bool = Field(False, alias="UseFloorColor")
    # Every notification is POSTed as JSON to each of these URLs (fleet.push.Webhooks).
    webhook_urls: tuple[WebhookUrl, ...] = Field((), alias="WebhookUrls", max_length=10)
    webhook_retries: int = Field(3, alias="WebhookRetries", ge=0, le=10)
    webhook_timeout_s: float = Field(5.0, alias="WebhookTimeoutS", gt=0, le=60)

    @model_validator(mode="after")
    def _weights_ordered(self) -> FleetSettings:
        if self.min_weight_kg >= self.max_weight_kg:
            msg = "MinWeightKg must be below MaxWeightKg"
            raise ValueError(msg)
        return self

    def public(self) -> dict[str, Any]:
        return self.model_dump(by_alias=True)


class SettingsUpdate(BaseModel):
    """A partial update: only the keys given change (strict: ``"yes"`` is not a boolean)."""

    model_config = ConfigDict(extra="forbid", strict=True)

    AutoAccept: bool | None = None
    PreemptBusyRobot: bool | None = None
    AcceptedTimeoutS: float | None = Field(None, gt=0, le=86400)
    ArrivedTimeoutS: float | None = Field(None, gt=0, le=86400)
    DeliveryArrivedTimeoutS: float | None = Field(None, gt=0, le=86400)
    LaundryLoadedTimeoutS: float | None = Field(None, gt=0, le=86400)
    GoingToBaseTimeoutS: float | None = Field(None, gt=0, le=86400)
    TimeoutCheckPeriodS: float | None = Field(None, gt=0, le=3600)
    OfflineAfterS: float | None = Field(None, gt=0, le=86400)
    OfflineCheckPeriodS: float | None = Field(None, gt=0, le=3600)
    MinWeightKg: float | None = Field(None, ge=0, le=1000)
    MaxWeightKg: float | None = Field(None, gt=0, le=1000)
    RequireWeightCheck: bool | None = None
    UnloadSettledS: float | None = Field(None, ge=0, le=3600)
    BaseQueueMarginDb: float | None = Field(None, ge=0, le=60)
    UseFloorColor: bool | None = None
    WebhookUrls: Annotated[list[WebhookUrl], Field(max_length=10)] | None = None
    WebhookRetries: int | None = Field(None, ge=0, le=10)
    WebhookTimeoutS: float | None = Field(None, gt=0, le=60)

    def given(self) -> dict[str, Any]:
        return {k: v for k, v in self.model_dump().items() if v is not None}


_STORED = select(Setting.key, Setting.value)
_KNOWN = frozenset(f.alias for f in FleetSettings.model_fields.values())


async def load_settings(session: AsyncSession | AsyncConnection) -> FleetSettings:
    """The stored settings (an ORM session or a Core connection reads them alike)."""
    return _parsed(tuple((key, value) for key, value in (await session.execute(_STORED)).all()))


def read_settings(conn: Connection) -> FleetSettings:
    """``load_settings`` in a function of a synchronous connection (``Database.run_read``)."""
    return _parsed(tuple((key, value) for key, value in conn.execute(_STORED)))


@functools.lru_cache(maxsize=16)
def _parsed(rows: tuple[tuple[str, str], ...]) -> FleetSettings:
    """The settings of these stored rows (they rarely change, and FleetSettings is frozen: one
    instance serves every reader of the same rows)."""
    stored = {key: json.loads(value) for key, value in rows}
    return FleetSettings.model_validate({k: v for k, v in stored.items() if k in _KNOWN})


async def store_settings(session: AsyncSession, values: dict[str, Any]) -> FleetSettings:
    """Validate the merged settings, then write the given keys. Raises ValueError if invalid."""
    current = (await load_settings(session)).public()
    merged = FleetSettings.model_validate({**current, **values})
    for key in values:
        value = json.dumps(merged.public()[key])
        row = await session.get(Setting, key)
        if row is None:
            session.add(Setting(key=key, value=value))
        else:
            row.value = value
    announce(session, SITE)
    return merged
