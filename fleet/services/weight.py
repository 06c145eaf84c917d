"""Weight validation: the load the robot reports enables the customer's confirmation
(seed section 11)."""

from __future__ import annotations

from datetime import datetime
from typing import Protocol

from sqlalchemy.ext.asyncio import AsyncSession

from fleet.models import Request
from fleet.services.notify import notify
from fleet.settings import FleetSettings
from fleet.status import Status


class Weighed(Protocol):
    """What the confirmations read of a request (a ``Request`` or a row of its columns)."""

    @property
    def status(self) -> str: ...
    @property
    def weight_kg(self) -> float | None: ...


def load_ok(weight_kg: float | None, cfg: FleetSettings) -> bool:
    """Laundry loaded: above the minimum and below the maximum."""
    return weight_kg is not None and cfg.min_weight_kg < weight_kg < cfg.max_weight_kg


def unload_ok(weight_kg: float | None, cfg: FleetSettings) -> bool:
    """Laundry taken out: below the minimum again."""
    return weight_kg is not None and weight_kg < cfg.min_weight_kg


def can_confirm_loaded(request: Weighed, cfg: FleetSettings) -> bool:
    return request.status == Status.ARRIVED_AT_ROOM and (
        not cfg.require_weight_check or load_ok(request.weight_kg, cfg))


def can_confirm_unloaded(request: Weighed, cfg: FleetSettings) -> bool:
    return request.status == Status.ARRIVED_FOR_DELIVERY and (
        not cfg.require_weight_check or unload_ok(request.weight_kg, cfg))


def needs_weight(request: Request | None) -> bool:
    return request is not None and request.status in (
        Status.ARRIVED_AT_ROOM, Status.ARRIVED_FOR_DELIVERY)


def evaluate(
    session: AsyncSession, now: datetime, cfg: FleetSettings, request: Request,
    weight_kg: float | None,
) -> None:
    """Record the weight the robot reports while it waits at the customer's room."""
    if not needs_weight(request) or weight_kg is None:
        return
    if request.weight_kg != weight_kg:
        request.weight_kg = weight_kg
    if request.status != Status.ARRIVED_AT_ROOM:
        return
    over = weight_kg > cfg.min_weight_kg and weight_kg >= cfg.max_weight_kg
    if over and not request.overweight:
        text = (f"Overweight: {weight_kg:.1f} kg exceeds the maximum of "
                f"{cfg.max_weight_kg:.1f} kg; please remove some laundry.")
        for recipient in ("customer", "admin"):
            notify(session, now, recipient=recipient, kind="weight.overweight", level="warning",
                   request=request, message=text)
    if request.overweight != over:
        request.overweight = over
