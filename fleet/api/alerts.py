"""Alerts for the laundry staff (issue 27): list, acknowledge, resolve. Admin tokens only."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Depends, Path, Query
from fastapi import Request as HttpRequest
from sqlalchemy import select

from fleet.api.auth import Admin
from fleet.api.auth import admin as admin_only
from fleet.api.deps import AUTH_ERRORS, errors, server_of
from fleet.api.schemas import AlertOut, AlertResolve
from fleet.models import Alert
from fleet.services import alerts
from fleet.services.alerts import LAUNDRY_KINDS, LaundryAt

router = APIRouter(prefix="/api/alerts", tags=["alerts"], responses=AUTH_ERRORS,
                   dependencies=[Depends(admin_only)])

AlertId = Annotated[int, Path(ge=1, le=2**31 - 1)]


def alert_out(alert: Alert) -> AlertOut:
    return AlertOut(
        Id=alert.id, CreatedAt=alert.created_at, Kind=alert.kind, Level=alert.level,
        RobotName=alert.robot_name, RequestId=alert.request_id, Message=alert.message,
        IsLaundry=alert.kind in LAUNDRY_KINDS, AcknowledgedAt=alert.acknowledged_at,
        AcknowledgedBy=alert.acknowledged_by, ResolvedAt=alert.resolved_at,
        ResolvedBy=alert.resolved_by, Resolution=alert.resolution, Code=alert.code)


@router.get("", response_model=list[AlertOut])
async def list_alerts(
    http: HttpRequest,
    open_only: Annotated[bool | None, Query(alias="open")] = None,
    request_id: Annotated[int | None, Query(ge=1, le=2**31 - 1)] = None,
    robot: Annotated[str | None, Query(min_length=1, max_length=100)] = None,
    limit: Annotated[int, Query(ge=1, le=1000)] = 100,
) -> list[AlertOut]:
    """Alerts, newest first; ``open=true``: only those not resolved yet (``false``: only
    resolved ones)."""
    query = select(Alert).order_by(Alert.id.desc()).limit(limit)
    if open_only is not None:
        query = query.where(Alert.resolved_at.is_(None) if open_only
                            else Alert.resolved_at.is_not(None))
    if request_id is not None:
        query = query.where(Alert.request_id == request_id)
    if robot is not None:
        query = query.where(Alert.robot_name == robot)
    async with server_of(http).db.read() as session:
        return [alert_out(a) for a in (await session.execute(query)).scalars()]


@router.post("/{alert_id}/acknowledge", response_model=AlertOut, responses=errors(404, 409))
async def acknowledge(alert_id: AlertId, http: HttpRequest, caller: Admin) -> AlertOut:
    """A person has seen the alert (it stays open until resolved); 409 once resolved."""
    server = server_of(http)
    async with server.db.write() as session:
        return alert_out(await alerts.acknowledge(session, server.clock(), alert_id,
                                                  caller.subject))


@router.post("/{alert_id}/resolve", response_model=AlertOut,
             responses=errors(404, 409, 413))
async def resolve(alert_id: AlertId, http: HttpRequest, caller: Admin,
                  body: AlertResolve | None = None) -> AlertOut:
    """Close the alert. For a laundry alert (``IsLaundry``) ``{"LaundryAt": "robot" | "base"
    | "customer"}`` says where the laundry is, and the request and its robot follow: on the
    robot, they keep each other; at base, dirty laundry goes on as Washing and clean
    laundry is held at base as Washing for delivery again, the robot released; returned to
    the customer, the request ends Cancelled (refund if paid). 422 without LaundryAt for a
    laundry alert, or with it for another; 409 once resolved."""
    server = server_of(http)
    where = LaundryAt(body.LaundryAt) if body is not None and body.LaundryAt else None
    await server.flush_pings()  # a robot released now is dispatched on its latest report
    async with server.db.write() as session:
        return alert_out(await alerts.resolve(session, server.clock(), alert_id,
                                              caller.subject, where))
