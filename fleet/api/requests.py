"""Customer and admin calls on laundry requests (contract "Fleet request API").

A customer token reaches only its own requests; an admin token reaches all of them.
"""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Path, Query
from fastapi import Request as HttpRequest
from sqlalchemy import select
from sqlalchemy.ext.asyncio import AsyncSession

from fleet.api.auth import CustomerOrAdmin, check_customer
from fleet.api.deps import AUTH_ERRORS, ERRORS, errors, request_out, server_of
from fleet.api.request_reads import newest_requests, one_request
from fleet.api.schemas import RequestCreate, RequestOut
from fleet.errors import Forbidden, NotFound
from fleet.models import Request
from fleet.services.lifecycle import apply_action, create_request
from fleet.settings import load_settings
from fleet.status import Action, Status
from fleet.tokens import Principal, Role

router = APIRouter(prefix="/api/requests", tags=["requests"], responses=AUTH_ERRORS)

RequestId = Annotated[int, Path(ge=1, le=2**31 - 1)]
# What a customer may do to its own request; the rest is the laundry staff's (admin).
CUSTOMER_ACTIONS = frozenset({Action.CANCEL, Action.CONFIRM_LOADED, Action.CONFIRM_UNLOADED,
                              Action.PAY})


@router.post("", status_code=201, response_model=RequestOut,
             responses={**ERRORS, 503: {"description": "No robot can serve"}})
async def create(body: RequestCreate, http: HttpRequest, caller: CustomerOrAdmin) -> RequestOut:
    """A customer asks for a pickup (409 if they already have an active request)."""
    check_customer(caller, body.CustomerId, f"customer {body.CustomerId}")
    server = server_of(http)
    await server.flush_pings()  # assignment sees every robot's latest report
    async with server.db.write() as session:
        cfg = await load_settings(session)
        request = await create_request(session, server.clock(), cfg, body.CustomerId)
        return await request_out(session, cfg, request)


@router.get("", response_model=list[RequestOut])
async def list_requests(
    http: HttpRequest,
    caller: CustomerOrAdmin,
    status: Annotated[Status | None, Query()] = None,
    customer_id: Annotated[int | None, Query(ge=1, le=2**31 - 1)] = None,
    limit: Annotated[int, Query(ge=1, le=1000)] = 100,
) -> list[RequestOut]:
    """Requests, newest first (a customer sees only its own)."""
    return await newest_requests(server_of(http), caller, status, customer_id, limit)


@router.get("/{request_id}", response_model=RequestOut, responses=errors(404))
async def get(request_id: RequestId, http: HttpRequest, caller: CustomerOrAdmin) -> RequestOut:
    return await one_request(server_of(http), caller, request_id)


@router.post("/{request_id}/{action}", response_model=RequestOut,
             responses={**errors(404, 409), 503: {"description": "No robot to deliver"}})
async def act(request_id: RequestId, action: Action, http: HttpRequest,
              caller: CustomerOrAdmin) -> RequestOut:
    """accept, decline, cancel, confirm-loaded, confirm-unloaded, washing-started,
    washing-done, pay; 409 with a message when the status does not allow it. A customer may
    cancel, confirm-loaded, confirm-unloaded and pay its own requests."""
    server = server_of(http)
    if caller.role != Role.ADMIN:
        async with server.db.read() as session:
            await _check_may_act(session, caller, request_id, action)
    await server.flush_pings()  # a freed robot is dispatched on its latest report
    async with server.db.write() as session:
        await _check_may_act(session, caller, request_id, action)
        cfg = await load_settings(session)
        request = await apply_action(session, server.clock(), cfg, request_id, action)
        return await request_out(session, cfg, request)


async def _check_may_act(session: AsyncSession, caller: Principal, request_id: int,
                         action: Action) -> None:
    """403 before anything is changed, for a customer acting on what is not theirs to do."""
    if caller.role == Role.ADMIN:
        return
    if action not in CUSTOMER_ACTIONS:
        msg = f"{action} is for the laundry staff (an admin token)"
        raise Forbidden(msg)
    customer_id = (await session.execute(
        select(Request.customer_id).where(Request.id == request_id))).scalar()
    if customer_id is None:
        msg = f"request {request_id} does not exist"
        raise NotFound(msg)
    check_customer(caller, customer_id, f"request {request_id}")
