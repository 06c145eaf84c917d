"""What every router needs: the server, and turning rows into response bodies."""

from __future__ import annotations

from datetime import datetime
from typing import Protocol

from fastapi import Request as HttpRequest
from sqlalchemy import select
from sqlalchemy.ext.asyncio import AsyncSession

from fleet.api.schemas import ErrorOut, FaultOut, PoseOut, RefundOut, RequestOut, RobotOut
from fleet.models import Refund, Request, Robot
from fleet.server import FleetServer
from fleet.services.common import waiting_for
from fleet.services.weight import Weighed, can_confirm_loaded, can_confirm_unloaded
from fleet.settings import FleetSettings

_TEXT = {
    401: "No valid bearer token (missing, malformed, unknown or revoked)",
    403: "The token's role or owner may not do this",
    404: "Not found", 409: "Not allowed now", 413: "Request body too large",
    422: "Bad input (the body, a path or query parameter)",
    429: "Too many failed authentications from this address",
}
_HEADERS: dict[int, dict[str, object]] = {
    401: {"WWW-Authenticate": {"description": "Bearer", "schema": {"type": "string"}}},
    429: {"Retry-After": {"description": "Seconds to wait", "schema": {"type": "integer"}}},
}


def errors(*codes: int) -> dict[int | str, dict[str, object]]:
    """OpenAPI ``responses`` for these 4xx codes, all with the one error body (``ErrorOut``)."""
    return {code: {"description": _TEXT[code], "model": ErrorOut,
                   **({"headers": _HEADERS[code]} if code in _HEADERS else {})}
            for code in codes}


# Every authenticated operation may answer these (routers add them to each route).
AUTH_ERRORS = errors(401, 403, 422, 429)
ERRORS = errors(404, 409, 413)


def server_of(http: HttpRequest) -> FleetServer:
    server = http.app.state.fleet
    assert isinstance(server, FleetServer)
    return server


async def request_out(session: AsyncSession, cfg: FleetSettings, request: Request) -> RequestOut:
    robot = (await session.get(Robot, request.assigned_robot_id)
             if request.assigned_robot_id is not None else None)
    refund = (await session.execute(
        select(Refund).where(Refund.request_id == request.id))).scalar_one_or_none()
    return request_body(request, robot.name if robot is not None else None, cfg,
                        refund_out(refund.id, refund.created_at, refund.reason)
                        if refund is not None else None)


def refund_out(refund_id: int | None, created_at: datetime | None,
               reason: str | None) -> RefundOut | None:
    """A request's refund as the API shows it (None: no refund; the columns of an outer
    join are then null)."""
    if refund_id is None or created_at is None or reason is None:
        return None
    return RefundOut(Id=refund_id, CreatedAt=created_at, Reason=reason)


class RequestFields(Weighed, Protocol):
    """What the API shows of a request: a ``Request``, or a row of its columns."""

    @property
    def id(self) -> int: ...
    @property
    def customer_id(self) -> int: ...
    @property
    def is_approved(self) -> bool: ...
    @property
    def created_at(self) -> datetime: ...
    @property
    def status_changed_at(self) -> datetime: ...
    @property
    def is_paid(self) -> bool: ...
    @property
    def refund_due(self) -> bool: ...
    @property
    def cancel_reason(self) -> str | None: ...
    @property
    def cancelled_from(self) -> str | None: ...
    @property
    def disposition(self) -> str: ...
    @property
    def robot_returned(self) -> bool: ...
    @property
    def overweight(self) -> bool: ...
    @property
    def admin_alert(self) -> str | None: ...
    @property
    def washing_done_at(self) -> datetime | None: ...


def request_body(request: RequestFields, robot_name: str | None,
                 cfg: FleetSettings, refund: RefundOut | None = None) -> RequestOut:
    """A request as the API shows it (``robot_name``: the assigned robot's)."""
    return RequestOut(
        Id=request.id, CustomerId=request.customer_id, Status=request.status,
        AssignedRobotName=robot_name,
        IsApproved=request.is_approved, CreatedAt=request.created_at,
        StatusChangedAt=request.status_changed_at, IsPaid=request.is_paid,
        RefundDue=request.refund_due, CancelReason=request.cancel_reason,
        CancelledFrom=request.cancelled_from, LaundryDisposition=request.disposition,
        RobotReturned=request.robot_returned, WeightKg=request.weight_kg,
        Overweight=request.overweight,
        CanConfirmLoaded=can_confirm_loaded(request, cfg),
        CanConfirmUnloaded=can_confirm_unloaded(request, cfg),
        AdminAlert=request.admin_alert, Refund=refund,
        DeliveryQueued=request.washing_done_at is not None,
    )


def robot_status(robot: Robot) -> str:
    if not robot.is_active:
        return "Inactive"
    if robot.is_offline:
        return "Offline"
    if robot.emergency_stop or robot.estop_active:
        return "EmergencyStop"
    if robot.maintenance_mode:
        return "Maintenance"
    return "Busy" if robot.current_request_id is not None else "Available"


def robot_out(robot: Robot) -> RobotOut:
    return RobotOut(
        Name=robot.name, Status=robot_status(robot), IsActive=robot.is_active,
        IsOffline=robot.is_offline, EmergencyStop=robot.emergency_stop,
        MaintenanceMode=robot.maintenance_mode, CurrentRequestId=robot.current_request_id,
        LastPingAt=robot.last_ping_at, LastAssignedAt=robot.last_assigned_at,
        WeightKg=robot.weight_kg, State=robot.state, EmergencyStopActive=robot.estop_active,
        Fault=(FaultOut(Code=robot.fault_code, Message=robot.fault_message or "")
               if robot.fault_code is not None else None),
        BatteryPct=robot.battery_pct,
        WaitingFor=waiting_for(robot.unload_pending, robot.waiting_for_line),
        Profile=robot.profile, Pose=_pose_out(robot), Place=robot.place, Job=robot.job,
        LastStatusAt=robot.status_at,
    )


def _pose_out(robot: Robot) -> PoseOut | None:
    if robot.pose_x_m is None or robot.pose_y_m is None or robot.pose_theta_rad is None:
        return None
    return PoseOut(X=robot.pose_x_m, Y=robot.pose_y_m, Theta=robot.pose_theta_rad,
                   Map=robot.map_name)
