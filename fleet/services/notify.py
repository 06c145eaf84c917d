"""Notifications to customers and admins, stored in the database (and logged)."""

from __future__ import annotations

from datetime import datetime

import structlog
from pydantic import BaseModel
from sqlalchemy.ext.asyncio import AsyncSession

from fleet.models import Notification, Request

log = structlog.get_logger(__name__)


class NotificationOut(BaseModel):
    """A notification as the API, the event stream and the webhooks show it."""

    Id: int
    CreatedAt: datetime
    Recipient: str
    Level: str
    Kind: str
    Message: str
    CustomerId: int | None
    RequestId: int | None
    RobotName: str | None


def notification_out(n: Notification) -> NotificationOut:
    return NotificationOut(
        Id=n.id, CreatedAt=n.created_at, Recipient=n.recipient, Level=n.level, Kind=n.kind,
        Message=n.message, CustomerId=n.customer_id, RequestId=n.request_id,
        RobotName=n.robot_name)

CREATED = "fleet.notifications"
"""``session.info`` key: the notifications a transaction created (pushed after its commit)."""


def notify(
    session: AsyncSession,
    now: datetime,
    *,
    recipient: str,
    kind: str,
    message: str,
    level: str = "info",
    request: Request | None = None,
    robot_name: str | None = None,
) -> None:
    """Store a notification for ``recipient`` ("customer" or "admin"); once the transaction
    commits it is pushed (``fleet.push``)."""
    row = Notification(
        created_at=now, recipient=recipient, level=level, kind=kind, message=message,
        customer_id=request.customer_id if request is not None else None,
        request_id=request.id if request is not None else None,
        robot_name=robot_name,
    )
    session.add(row)
    session.info.setdefault(CREATED, []).append(row)
    log.info("fleet.notify", recipient=recipient, kind=kind, level=level,
             request_id=request.id if request is not None else None, robot=robot_name)
