"""Request and response bodies, PascalCase as the contracts say. Inputs are strict and bounded
so bad input is a 4xx with a message, never a database error."""

from __future__ import annotations

from datetime import datetime
from typing import Annotated, Literal

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, StringConstraints

from fleet.services.notify import NotificationOut

__all__ = ["NotificationOut"]  # the notification's public form is the service's


def _whole_number(value: object) -> object:
    """JSON has one number type: ``3.0`` is the integer 3 (as the OpenAPI schema's "integer"
    means); ``3.5``, ``true`` and ``"3"`` stay refused by the strict int check."""
    if isinstance(value, float) and value.is_integer():
        return int(value)
    return value


# Last in an Annotated (it then runs first), so the constraints before it stay in the schema.
Whole = BeforeValidator(_whole_number)
Id = Annotated[int, Field(strict=True, ge=1, le=2**31 - 1), Whole]
Text = Annotated[str, StringConstraints(min_length=1, max_length=100,
                                        pattern=r"^[^\x00-\x1f\x7f]+$")]
ShortText = Annotated[str, StringConstraints(min_length=1, max_length=32,
                                             pattern=r"^[^\x00-\x1f\x7f]+$")]
"""A short name such as a floor colour (the database column holds 32 characters)."""
Mac = Annotated[str, StringConstraints(pattern=r"^[0-9A-Fa-f]{2}(:[0-9A-Fa-f]{2}){5}$")]
Real = Annotated[float, Field(strict=True, allow_inf_nan=False, ge=-1e6, le=1e6)]
Rssi = Annotated[int, Field(strict=True, ge=-200, le=50), Whole]
Flag = Annotated[bool, Field(strict=True)]
ProfileName = Annotated[str, StringConstraints(min_length=1, max_length=40,
                                               pattern=r"^[^\x00-\x1f\x7f]+$")]
"""A robot profile's name (``vacuum``, ``delivery`` ...)."""
JobText = Annotated[str, StringConstraints(min_length=1, max_length=200,
                                           pattern=r"^[^\x00-\x1f\x7f]+$")]
"""What a robot serves now, in its words (``order 7``, ``cabinet C3``)."""


class Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


class RequestCreate(Strict):
    CustomerId: Id


class RefundOut(BaseModel):
    Id: int
    CreatedAt: datetime
    Reason: str


class RequestOut(BaseModel):
    Id: int
    CustomerId: int
    Status: str
    AssignedRobotName: str | None
    IsApproved: bool
    CreatedAt: datetime
    StatusChangedAt: datetime
    IsPaid: bool
    RefundDue: bool
    CancelReason: str | None
    CancelledFrom: str | None
    LaundryDisposition: str
    RobotReturned: bool
    WeightKg: float | None
    Overweight: bool
    CanConfirmLoaded: bool
    CanConfirmUnloaded: bool
    AdminAlert: str | None
    DeliveryQueued: bool = False
    """Washed (``washing-done``) and waiting for a robot that may go to deliver it."""
    Refund: RefundOut | None = None
    """The refund owed for a paid request that was cancelled."""


class DetectedBeacon(BaseModel):
    model_config = ConfigDict(extra="ignore")

    MacAddress: Annotated[str, StringConstraints(min_length=1, max_length=64)]
    Uuid: Annotated[str, StringConstraints(max_length=64)] | None = None
    Major: Annotated[int, Field(strict=True, ge=0, le=65535), Whole] | None = None
    Minor: Annotated[int, Field(strict=True, ge=0, le=65535), Whole] | None = None
    Rssi: Rssi
    Distance: Real | None = None


class FaultIn(BaseModel):
    """The fault that keeps the robot from its job (``line_lost``, ``blocked``...)."""

    model_config = ConfigDict(extra="ignore")

    Code: Annotated[str, StringConstraints(min_length=1, max_length=60,
                                           pattern=r"^[^\x00-\x1f\x7f]+$")]
    Message: Annotated[str, StringConstraints(max_length=500)] = ""


class DataExchangeIn(BaseModel):
    model_config = ConfigDict(extra="ignore")

    RobotName: Annotated[Text | None, Field(description=(
        "The robot's name, as in the URL. Optional; when given it must equal the path's "
        "RobotName: a body that names another robot is refused with 422."))] = None
    Timestamp: datetime | None = None
    DetectedBeacons: Annotated[list[DetectedBeacon], Field(max_length=512)] = []
    IsInTarget: Flag = False
    WeightKg: Real | None = None
    UltrasonicDistance: Real | None = None
    # Added to the contract (issue 27): what the robot knows of itself. All optional.
    State: Text | None = None
    """The daemon's dotted state path, e.g. ``mission.to_room``."""
    EmergencyStopActive: Flag | None = None
    Fault: FaultIn | None = None
    BatteryPct: Annotated[float, Field(strict=True, allow_inf_nan=False, ge=0, le=100)] | None \
        = None
    Queued: Flag = False
    """At base, queued behind the robot ahead on the line (``IsInTarget`` is true too): it
    pulls up to the base beacon as the queue moves, so the base beacons stay its targets."""
    # Added (issue 29): what the site status carries for every robot. All optional.
    Profile: ProfileName | None = None
    Place: Text | None = None
    """The last room whose beacon it arrived at."""
    Job: JobText | None = None


class PoseIn(BaseModel):
    """Where a robot stands on its map: metres and radians in the frame ``Map`` names."""

    model_config = ConfigDict(extra="ignore")

    X: Real
    Y: Real
    Theta: Annotated[float, Field(strict=True, allow_inf_nan=False, ge=-7, le=7)]
    Map: Text | None = None
    """The map's name (a site map's file stem; ``odom``: where the robot started)."""


class StatusIn(BaseModel):
    """Any robot's site status (issue 29), every ``fleet.period_s``. All optional but the
    path's robot."""

    model_config = ConfigDict(extra="ignore")

    RobotName: Annotated[Text | None, Field(description=(
        "The robot's name, as in the URL. Optional; when given it must equal the path's "
        "RobotName: a body that names another robot is refused with 422."))] = None
    Timestamp: datetime | None = None
    Profile: ProfileName | None = None
    State: Text | None = None
    """The daemon's dotted state path, e.g. ``docking.approach``."""
    EmergencyStopActive: Flag | None = None
    Fault: FaultIn | None = None
    BatteryPct: Annotated[float, Field(strict=True, allow_inf_nan=False, ge=0, le=100)] | None \
        = None
    Pose: PoseIn | None = None
    """A LiDAR robot's map pose (or a robot's odometry, ``Map`` "odom")."""
    Place: Text | None = None
    """The last room or beacon of a robot on a line."""
    Job: JobText | None = None
    """What it serves now (a request, an order, a cabinet task)."""


class StatusOut(BaseModel):
    """The staff's orders, as in the data exchange's reply."""

    EmergencyStop: bool
    MaintenanceMode: bool


class ActiveBeacon(BaseModel):
    MacAddress: str
    Name: str
    RoomName: str
    RssiThreshold: int
    IsNavigationTarget: bool


class DataExchangeOut(BaseModel):
    ActiveBeacons: list[ActiveBeacon]
    RequestId: int | None = None
    RequestStatus: str | None = None
    IsLineFollowing: bool
    FollowColor: str | None
    EmergencyStop: bool
    MaintenanceMode: bool
    WaitingFor: Literal["unload", "line"] | None = None
    """Why the robot, free, is not sent out: its load must come off first ("unload"), or the
    painted line its next request needs is in use by another robot ("line")."""


class RobotIn(Strict):
    Name: Text


class RobotPatch(Strict):
    IsActive: Flag | None = None
    EmergencyStop: Flag | None = None
    MaintenanceMode: Flag | None = None


class MaintenanceIn(Strict):
    On: Flag
    """True: into maintenance; false: out of it."""


class FaultOut(BaseModel):
    Code: str
    Message: str


class PoseOut(BaseModel):
    X: float
    Y: float
    Theta: float
    Map: str | None


class RobotOut(BaseModel):
    Name: str
    Status: str
    IsActive: bool
    IsOffline: bool
    EmergencyStop: bool
    MaintenanceMode: bool
    CurrentRequestId: int | None
    LastPingAt: datetime | None
    LastAssignedAt: datetime | None
    WeightKg: float | None
    State: str | None = None
    EmergencyStopActive: bool | None = None
    Fault: FaultOut | None = None
    BatteryPct: float | None = None
    WaitingFor: Literal["unload", "line"] | None = None
    # Added (issue 29): the site status any robot reports.
    Profile: str | None = None
    Pose: PoseOut | None = None
    Place: str | None = None
    Job: str | None = None
    LastStatusAt: datetime | None = None


class RoomIn(Strict):
    Name: Text
    FloorColor: ShortText | None = None


class RoomOut(BaseModel):
    Id: int
    Name: str
    FloorColor: str | None


class BeaconIn(Strict):
    MacAddress: Mac
    Name: Text
    RoomName: Text
    RssiThreshold: Rssi = -70
    IsBase: Flag = False
    IsActive: Flag = True


class BeaconOut(BaseModel):
    Id: int
    MacAddress: str
    Name: str
    RoomName: str
    RssiThreshold: int
    IsBase: bool
    IsActive: bool


class LineIn(Strict):
    Name: Text
    Rooms: Annotated[list[Text], Field(max_length=100)]
    """The rooms on this painted line (replacing those it had; none: the line is removed)."""


class LineOut(BaseModel):
    Name: str
    Rooms: list[str]


class CustomerIn(Strict):
    Name: Text
    RoomName: Text | None = None
    BeaconMacAddress: Mac | None = None


class CustomerOut(BaseModel):
    Id: int
    Name: str
    RoomId: int | None
    BeaconMacAddress: str | None


class AlertOut(BaseModel):
    Id: int
    CreatedAt: datetime
    Kind: str
    Level: str
    RobotName: str | None
    RequestId: int | None
    Message: str
    IsLaundry: bool
    """Resolving it needs ``LaundryAt``: where the laundry is."""
    AcknowledgedAt: datetime | None
    AcknowledgedBy: str | None
    ResolvedAt: datetime | None
    ResolvedBy: str | None
    Resolution: str | None
    Code: str | None = None
    """What a ``robot.fault`` is: ``docking_gave_up``, a RelayBot error category, or the
    robot's fault code (issue 29)."""


class AlertResolve(Strict):
    LaundryAt: Literal["robot", "base", "customer"] | None = None
    """For a laundry alert (required there): where the staff found the laundry."""


class FieldError(BaseModel):
    loc: list[str | int]
    msg: str
    type: str


class ErrorOut(BaseModel):
    """Every 4xx answer: ``detail`` says what was wrong, for a person; a 422 also lists each
    bad field in ``errors``."""

    detail: str
    errors: list[FieldError] | None = None
