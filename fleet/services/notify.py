"""Notifications to customers and admins, stored in the database (and logged)."""

from __future__ import annotations

from datetime import datetime

import structlog
from sqlalchemy.ext.asyncio import AsyncSession

from fleet.models import Notification, Request

log = structlog.get_logger(__name__)


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
    """Store a notification for ``recipient`` ("customer" or "admin")."""
    session.add(Notification(
        created_at=now, recipient=recipient, level=level, kind=kind, message=message,
        customer_id=request.customer_id if request is not None else None,
        request_id=request.id if request is not None else None,
        robot_name=robot_name,
    ))
    log.info("fleet.notify", recipient=recipient, kind=kind, level=level,
             request_id=request.id if request is not None else None, robot=robot_name)
