"""The robot's 1 s data exchange (contract "Fleet data exchange")."""

from __future__ import annotations

import functools
import json
from typing import Annotated

from fastapi import APIRouter, Depends, Path, Response
from fastapi import Request as HttpRequest

from fleet.api.auth import Caller
from fleet.api.deps import AUTH_ERRORS, errors, server_of
from fleet.api.schemas import DataExchangeIn, DataExchangeOut, StatusIn, StatusOut
from fleet.errors import FleetError, Forbidden, Invalid
from fleet.server import FleetServer
from fleet.services.arrival import Sighting
from fleet.services.exchange import Reply, Report, exchange
from fleet.services.site_status import SiteStatus, answer_status
from fleet.tokens import Principal

router = APIRouter(prefix="/api/Robot", tags=["robot"], responses=AUTH_ERRORS)

RobotName = Annotated[str, Path(min_length=1, max_length=100, pattern=r"^[^\x00-\x1f\x7f]+$")]


_NAME_MISMATCH: dict[int | str, dict[str, object]] = {422: {**errors(422)[422], "description": (
    "Bad input (the body, a path parameter), or a body whose RobotName is not the path's")}}


async def own_robot(RobotName: RobotName, caller: Caller) -> Principal:  # noqa: N803
    """403 unless the token is the robot named in the path."""
    if not caller.is_robot(RobotName):
        msg = (f"only robot {RobotName!r} may post its data exchange or status "
               f"(this is a {caller.role} token)")
        raise Forbidden(msg)
    return caller


@router.post("/{RobotName}/data-exchange", response_model=DataExchangeOut,
             responses={**errors(404, 413), **_NAME_MISMATCH}, dependencies=[Depends(own_robot)])
async def data_exchange(
    RobotName: RobotName, body: DataExchangeIn, http: HttpRequest  # noqa: N803
) -> Response:
    """The robot reports beacons, arrival, weight and distance; the server answers with the
    beacon configuration, navigation targets and orders. The path names the robot (its token
    must be that robot's); a ``RobotName`` in the body, if any, must be the same name."""
    reply = await answer(server_of(http), RobotName, body)
    return Response(content=reply, media_type="application/json")


@router.post("/{RobotName}/status", response_model=StatusOut,
             responses={**errors(404, 413), **_NAME_MISMATCH}, dependencies=[Depends(own_robot)])
async def site_status(
    RobotName: RobotName, body: StatusIn, http: HttpRequest  # noqa: N803
) -> StatusOut:
    """Any robot's site status (issue 29), every ``fleet.period_s``: profile, state path,
    e-stop, fault, battery, pose on its map or last place, current job. Stored as the
    robot's latest (``GET /api/robots``); a fault raises a ``robot.fault`` alert. The answer
    carries the staff's orders, as the data exchange's does."""
    if body.RobotName is not None and body.RobotName != RobotName:
        msg = f"RobotName {body.RobotName!r} in the body does not match {RobotName!r} in the URL"
        raise Invalid(msg)
    server = server_of(http)
    pose = body.Pose
    orders = await answer_status(server.views, server.db, server.clock(), SiteStatus(
        robot_name=RobotName, profile=body.Profile, state=body.State,
        estop_active=body.EmergencyStopActive,
        fault_code=body.Fault.Code if body.Fault is not None else None,
        fault_message=body.Fault.Message if body.Fault is not None else None,
        battery_pct=body.BatteryPct,
        x_m=pose.X if pose is not None else None, y_m=pose.Y if pose is not None else None,
        theta_rad=pose.Theta if pose is not None else None,
        map_name=pose.Map if pose is not None else None, place=body.Place, job=body.Job),
        server.statuses)
    return StatusOut(EmergencyStop=orders.emergency_stop,
                     MaintenanceMode=orders.maintenance_mode)


async def answer(server: FleetServer, robot_name: str, body: DataExchangeIn) -> bytes:
    """One exchange, answered as JSON (the route and ``exchange_fast`` both call this).
    Raises FleetError for a request the server refuses."""
    if body.RobotName is not None and body.RobotName != robot_name:
        msg = f"RobotName {body.RobotName!r} in the body does not match {robot_name!r} in the URL"
        raise Invalid(msg)
    report = Report(
        robot_name=robot_name,
        sightings=[Sighting(b.MacAddress, b.Rssi) for b in body.DetectedBeacons],
        is_in_target=body.IsInTarget, weight_kg=body.WeightKg,
        ultrasonic_distance=body.UltrasonicDistance, state=body.State,
        estop_active=body.EmergencyStopActive,
        fault_code=body.Fault.Code if body.Fault is not None else None,
        fault_message=body.Fault.Message if body.Fault is not None else None,
        battery_pct=body.BatteryPct, queued=body.Queued, profile=body.Profile,
        place=body.Place, job=body.Job,
    )
    return reply_json(await exchange(server.db, server.clock, server.cache, server.views, report))


def encoded_error(exc: FleetError) -> bytes:
    """The body the app's FleetError handler sends (as starlette's JSONResponse encodes it)."""
    return json.dumps({"detail": exc.message}, ensure_ascii=False,
                      separators=(",", ":")).encode()


def reply_json(reply: Reply) -> bytes:
    """The reply as JSON, from pre-encoded parts (it is sent every second by every robot)."""
    nav = reply.navigation
    return (b'{"ActiveBeacons":[' + nav.encoded_beacons() + b"]," + _encoded_request(
        reply.request_id, reply.request_status) + _encoded_orders(
        nav.is_line_following, nav.follow_color, reply.emergency_stop, reply.maintenance_mode,
        reply.waiting_for))


def _encoded_request(request_id: int | None, status: str | None) -> bytes:
    """``RequestId`` and ``RequestStatus`` (an extension: the robot remembers which request
    it serves across a restart), each followed by a comma."""
    if request_id is None:
        return b'"RequestId":null,"RequestStatus":null,'
    return b'"RequestId":%d,"RequestStatus":%s,' % (request_id, json.dumps(status).encode())


@functools.lru_cache(maxsize=256)
def _encoded_orders(line_following: bool, follow_color: str | None, emergency_stop: bool,
                    maintenance_mode: bool, waiting_for: str | None) -> bytes:
    """The reply's fields after ``ActiveBeacons`` and the closing brace (``WaitingFor``: an
    extension, why a free robot is not sent out)."""
    return json.dumps({
        "IsLineFollowing": line_following, "FollowColor": follow_color,
        "EmergencyStop": emergency_stop, "MaintenanceMode": maintenance_mode,
        "WaitingFor": waiting_for,
    }, separators=(",", ":")).encode()[1:]
