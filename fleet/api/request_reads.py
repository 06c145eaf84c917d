"""Reading laundry requests: what ``GET /api/requests`` and ``GET /api/requests/{id}`` answer.

The routes (``fleet.api.requests``) and their fast path (``fleet.api.requests_fast``) both call
these, so the two cannot answer differently. Raises ``FleetError`` (404, 403) as the routes'
error handler words it.
"""

from __future__ import annotations

from typing import Any

from sqlalchemy import Connection, Select, bindparam, select

from fleet.api.auth import check_customer
from fleet.api.deps import refund_out, request_body
from fleet.api.schemas import RequestOut
from fleet.errors import NotFound
from fleet.models import Refund, Request, Robot
from fleet.server import FleetServer
from fleet.settings import FleetSettings, read_settings
from fleet.status import Status
from fleet.tokens import Principal, Role

# One Core query per read: the request's columns and its robot's name (the ORM took one query
# for the request and one for each robot, each through a session), shown from the row without
# making ORM objects. Built once: statements are immutable, and building one costs more than
# SQLAlchemy's cached compilation of it.
_WITH_ROBOT = (
    select(Request.__table__, Robot.name.label("assigned_robot_name"),
           Refund.id.label("refund_id"), Refund.created_at.label("refund_created_at"),
           Refund.reason.label("refund_reason"))
    .outerjoin(Robot, Robot.id == Request.assigned_robot_id)
    .outerjoin(Refund, Refund.request_id == Request.id))
_ONE = _WITH_ROBOT.where(Request.id == bindparam("request_id"))
_NEWEST_FIRST = _WITH_ROBOT.order_by(Request.id.desc())
_DEFAULT_LIMIT = 100
_NEWEST_FIRST_DEFAULT = _NEWEST_FIRST.limit(_DEFAULT_LIMIT)


async def one_request(server: FleetServer, caller: Principal, request_id: int) -> RequestOut:
    """The request ``request_id`` (404 if there is none, 403 if another customer's)."""

    def read(conn: Connection) -> RequestOut:
        row = conn.execute(_ONE, {"request_id": request_id}).first()
        if row is None:
            msg = f"request {request_id} does not exist"
            raise NotFound(msg)
        check_customer(caller, row.customer_id, f"request {request_id}")
        return _body(row, read_settings(conn))

    return await server.db.run_read(read)


async def newest_requests(server: FleetServer, caller: Principal, status: Status | None = None,
                          customer_id: int | None = None,
                          limit: int = _DEFAULT_LIMIT) -> list[RequestOut]:
    """Requests, newest first (a customer sees only its own; 403 for a customer asking for
    another's)."""
    if caller.role == Role.CUSTOMER:
        if customer_id is not None:
            check_customer(caller, customer_id, f"customer {customer_id}")
        customer_id = caller.customer_id
    query: Select[Any] = (
        _NEWEST_FIRST_DEFAULT if limit == _DEFAULT_LIMIT else _NEWEST_FIRST.limit(limit))
    if status is not None:
        query = query.where(Request.status == status)
    if customer_id is not None:
        query = query.where(Request.customer_id == customer_id)

    def read(conn: Connection) -> list[RequestOut]:
        cfg = read_settings(conn)
        return [_body(row, cfg) for row in conn.execute(query)]

    return await server.db.run_read(read)


def _body(row: Any, cfg: FleetSettings) -> RequestOut:
    return request_body(row, row.assigned_robot_name, cfg, refund_out(
        row.refund_id, row.refund_created_at, row.refund_reason))
