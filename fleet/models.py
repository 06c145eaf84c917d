"""The fleet database: rooms, beacons, customers, robots, requests, notifications, settings."""

from __future__ import annotations

from datetime import datetime

from sqlalchemy import Boolean, Float, ForeignKey, Integer, String, Text, false, true
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column

from fleet.clock import UtcDateTime
from fleet.status import Disposition, Status


class Base(DeclarativeBase):
    pass


class Room(Base):
    __tablename__ = "rooms"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    name: Mapped[str] = mapped_column(String(100), unique=True)
    floor_color: Mapped[str | None] = mapped_column(String(32), default=None)


class Beacon(Base):
    __tablename__ = "beacons"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    mac_address: Mapped[str] = mapped_column(String(17), unique=True)
    name: Mapped[str] = mapped_column(String(100))
    room_id: Mapped[int] = mapped_column(ForeignKey("rooms.id"), index=True)
    rssi_threshold_dbm: Mapped[int] = mapped_column(Integer, default=-70)
    is_base: Mapped[bool] = mapped_column(Boolean, default=False)
    is_active: Mapped[bool] = mapped_column(Boolean, default=True)


class LineRoom(Base):
    """A room on a painted line that several rooms share (a line is its rooms' rows)."""

    __tablename__ = "line_rooms"

    line: Mapped[str] = mapped_column(String(100), primary_key=True)
    room_id: Mapped[int] = mapped_column(ForeignKey("rooms.id"), primary_key=True)


class Customer(Base):
    __tablename__ = "customers"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    name: Mapped[str] = mapped_column(String(100))
    room_id: Mapped[int | None] = mapped_column(ForeignKey("rooms.id"), default=None)
    beacon_id: Mapped[int | None] = mapped_column(ForeignKey("beacons.id"), default=None)


class Robot(Base):
    __tablename__ = "robots"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    name: Mapped[str] = mapped_column(String(100), unique=True)
    is_active: Mapped[bool] = mapped_column(Boolean, default=True)
    is_offline: Mapped[bool] = mapped_column(Boolean, default=False)
    emergency_stop: Mapped[bool] = mapped_column(Boolean, default=False)
    maintenance_mode: Mapped[bool] = mapped_column(Boolean, default=False)
    # The request the robot serves, or the cancelled one it still brings back to base.
    current_request_id: Mapped[int | None] = mapped_column(Integer, default=None)
    last_ping_at: Mapped[datetime | None] = mapped_column(UtcDateTime(), default=None)
    last_assigned_at: Mapped[datetime | None] = mapped_column(UtcDateTime(), default=None)
    weight_kg: Mapped[float | None] = mapped_column(Float, default=None)
    ultrasonic_distance: Mapped[float | None] = mapped_column(Float, default=None)
    is_in_target: Mapped[bool] = mapped_column(Boolean, default=False)
    # What the robot reports of itself (issue 27; null: not reported, e.g. older firmware).
    state: Mapped[str | None] = mapped_column(String(100), default=None)
    """The daemon's dotted state path, e.g. ``mission.to_room``."""
    estop_active: Mapped[bool | None] = mapped_column(Boolean, default=None)
    """The robot's own e-stop latch (``emergency_stop`` is the server's order)."""
    fault_code: Mapped[str | None] = mapped_column(String(60), default=None)
    fault_message: Mapped[str | None] = mapped_column(String(500), default=None)
    battery_pct: Mapped[float | None] = mapped_column(Float, default=None)
    # Back at base with a load: not dispatched again until unloaded (fleet.services.unload).
    unload_pending: Mapped[bool] = mapped_column(Boolean, default=False,
                                                 server_default=false())
    unload_clear_since: Mapped[datetime | None] = mapped_column(UtcDateTime(), default=None)
    """Since when its load cell has read below the minimum, while ``unload_pending``."""
    waiting_for_line: Mapped[str | None] = mapped_column(String(100), default=None)
    """Free, but the next request it would serve is on this line, in use by another robot."""
    base_place: Mapped[int | None] = mapped_column(Integer, default=None)
    """Its place in the base queue (the lowest is at the front: back at base first), kept
    while it serves a request in case it never leaves base; None when it is away with no
    request (sent back to base), until it reports being there."""
    has_left_base: Mapped[bool] = mapped_column(Boolean, default=True, server_default=true())
    """Since its dispatch it has reported a place out of the base beacons' hearing (or it
    names no beacons): back, it joins the back of the queue; one that never left (cancelled
    before it went) keeps its place at the front."""
    # The site status any robot reports (issue 29, ``POST /api/Robot/{name}/status``; null:
    # never reported). A robot that reports only this is not a laundry robot: it stays
    # ``is_offline`` for the request queue, and is online by ``status_at``.
    profile: Mapped[str | None] = mapped_column(String(40), default=None)
    pose_x_m: Mapped[float | None] = mapped_column(Float, default=None)
    pose_y_m: Mapped[float | None] = mapped_column(Float, default=None)
    pose_theta_rad: Mapped[float | None] = mapped_column(Float, default=None)
    map_name: Mapped[str | None] = mapped_column(String(100), default=None)
    """The frame of the pose: the site map's name (``odom``: where the robot started)."""
    place: Mapped[str | None] = mapped_column(String(100), default=None)
    """The last room or beacon of a robot on a line."""
    job: Mapped[str | None] = mapped_column(String(200), default=None)
    """What it serves now, in the robot's words (``order 7``, ``cabinet C3``)."""
    status_at: Mapped[datetime | None] = mapped_column(UtcDateTime(), default=None)
    """When its last site status came."""


class Request(Base):
    __tablename__ = "requests"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    customer_id: Mapped[int] = mapped_column(ForeignKey("customers.id"), index=True)
    status: Mapped[str] = mapped_column(String(40), default=Status.PENDING, index=True)
    # Approved by an admin or by AutoAccept; an approved Pending request waits in the queue.
    is_approved: Mapped[bool] = mapped_column(Boolean, default=False)
    assigned_robot_id: Mapped[int | None] = mapped_column(ForeignKey("robots.id"), default=None)
    created_at: Mapped[datetime] = mapped_column(UtcDateTime())
    status_changed_at: Mapped[datetime] = mapped_column(UtcDateTime())
    accepted_at: Mapped[datetime | None] = mapped_column(UtcDateTime(), default=None)
    arrived_at: Mapped[datetime | None] = mapped_column(UtcDateTime(), default=None)
    washing_started_at: Mapped[datetime | None] = mapped_column(UtcDateTime(), default=None)
    washing_done_at: Mapped[datetime | None] = mapped_column(UtcDateTime(), default=None)
    """When the staff marked it washed, while it waits (Washing) for a robot to deliver it."""
    finished_at: Mapped[datetime | None] = mapped_column(UtcDateTime(), default=None)
    weight_kg: Mapped[float | None] = mapped_column(Float, default=None)
    overweight: Mapped[bool] = mapped_column(Boolean, default=False)
    is_paid: Mapped[bool] = mapped_column(Boolean, default=False)
    refund_due: Mapped[bool] = mapped_column(Boolean, default=False)
    cancel_reason: Mapped[str | None] = mapped_column(String(200), default=None)
    cancelled_from: Mapped[str | None] = mapped_column(String(40), default=None)
    disposition: Mapped[str] = mapped_column(String(40), default=Disposition.NONE)
    robot_returned: Mapped[bool] = mapped_column(Boolean, default=False)
    admin_alert: Mapped[str | None] = mapped_column(String(200), default=None)


class Notification(Base):
    __tablename__ = "notifications"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    created_at: Mapped[datetime] = mapped_column(UtcDateTime())
    recipient: Mapped[str] = mapped_column(String(20))  # customer | admin
    level: Mapped[str] = mapped_column(String(20))  # info | warning | critical
    kind: Mapped[str] = mapped_column(String(60))
    message: Mapped[str] = mapped_column(Text)
    customer_id: Mapped[int | None] = mapped_column(Integer, default=None)
    request_id: Mapped[int | None] = mapped_column(Integer, default=None, index=True)
    robot_name: Mapped[str | None] = mapped_column(String(100), default=None)


class Alert(Base):
    """Something the laundry staff must see to (issue 27): a robot offline holding laundry, a
    robot's fault, a request stuck on its way to base. Open until resolved."""

    __tablename__ = "alerts"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    created_at: Mapped[datetime] = mapped_column(UtcDateTime())
    kind: Mapped[str] = mapped_column(String(60))
    level: Mapped[str] = mapped_column(String(20))  # warning | critical
    robot_name: Mapped[str | None] = mapped_column(String(100), default=None, index=True)
    request_id: Mapped[int | None] = mapped_column(Integer, default=None, index=True)
    message: Mapped[str] = mapped_column(Text)
    acknowledged_at: Mapped[datetime | None] = mapped_column(UtcDateTime(), default=None)
    acknowledged_by: Mapped[str | None] = mapped_column(String(100), default=None)
    resolved_at: Mapped[datetime | None] = mapped_column(UtcDateTime(), default=None)
    resolved_by: Mapped[str | None] = mapped_column(String(100), default=None)
    resolution: Mapped[str | None] = mapped_column(String(60), default=None)
    code: Mapped[str | None] = mapped_column(String(60), default=None)
    """What a ``robot.fault`` is (issue 29): ``docking_gave_up``, a RelayBot error category
    (``stuck``, ``no_path`` ...) or the robot's own fault code; None for other kinds."""


class Refund(Base):
    """A refund owed to the customer of a paid request that was cancelled (seed section 12,
    "Process Refund if Payment Made")."""

    __tablename__ = "refunds"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    request_id: Mapped[int] = mapped_column(ForeignKey("requests.id"), unique=True)
    customer_id: Mapped[int] = mapped_column(Integer)
    created_at: Mapped[datetime] = mapped_column(UtcDateTime())
    reason: Mapped[str] = mapped_column(String(200))


class Setting(Base):
    __tablename__ = "settings"

    key: Mapped[str] = mapped_column(String(60), primary_key=True)
    value: Mapped[str] = mapped_column(Text)  # JSON


class Token(Base):
    """A bearer token of one caller (robot, customer or admin); only its SHA-256 is kept."""

    __tablename__ = "tokens"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    role: Mapped[str] = mapped_column(String(20))  # robot | customer | admin
    # The robot's name, the customer's id (as text) or the admin's name.
    subject: Mapped[str] = mapped_column(String(100))
    token_hash: Mapped[str] = mapped_column(String(64), unique=True)
    created_at: Mapped[datetime] = mapped_column(UtcDateTime())
    revoked_at: Mapped[datetime | None] = mapped_column(UtcDateTime(), default=None)


class ConsoleSession(Base):
    """A browser's login to the console (issue 29): a bearer token exchanged for a random
    session id in a cookie. Only the id's SHA-256 is kept, as for tokens; the CSRF token is
    the one every state-changing form of the session must carry."""

    __tablename__ = "console_sessions"

    id_hash: Mapped[str] = mapped_column(String(64), primary_key=True)
    token_id: Mapped[int] = mapped_column(ForeignKey("tokens.id"), index=True)
    csrf_token: Mapped[str] = mapped_column(String(64))
    created_at: Mapped[datetime] = mapped_column(UtcDateTime())
    expires_at: Mapped[datetime] = mapped_column(UtcDateTime())
    revoked_at: Mapped[datetime | None] = mapped_column(UtcDateTime(), default=None)
