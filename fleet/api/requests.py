"""Customer and admin calls on laundry requests (contract "Fleet request API")."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Path, Query
from fastapi import Request as HttpRequest
from sqlalchemy import select

from fleet.api.deps import ERRORS, request_out, server_of
from fleet.api.schemas import RequestCreate, RequestOut
from fleet.errors import NotFound
from fleet.models import Request
from fleet.services.lifecycle import apply_action, create_request
from fleet.settings import load_settings
from fleet.status import Action, Status

router = APIRouter(prefix="/api/requests", tags=["requests"])

RequestId = Annotated[int, Path(ge=1, le=2**31 - 1)]


@router.post("", status_code=201, response_model=RequestOut,
             responses={**ERRORS, 503: {"description": "No robot can serve"}})
async def create(body: RequestCreate, http: HttpRequest) -> RequestOut:
    """A customer asks for a pickup (409 if they already have an active request)."""
    server = server_of(http)
    async with server.db.write() as session:
        cfg = await load_settings(session)
        request = await create_request(session, server.clock(), cfg, body.CustomerId)
        return await request_out(session, cfg, request)


@router.get("", response_model=list[RequestOut])
async def list_requests(
    http: HttpRequest,
    status: Annotated[Status | None, Query()] = None,
    customer_id: Annotated[int | None, Query(ge=1, le=2**31 - 1)] = None,
    limit: Annotated[int, Query(ge=1, le=1000)] = 100,
) -> list[RequestOut]:
    """Requests, newest first."""
    query = select(Request).order_by(Request.id.desc()).limit(limit)
    if status is not None:
        query = query.where(Request.status == status)
    if customer_id is not None:
        query = query.where(Request.customer_id == customer_id)
    async with server_of(http).db.read() as session:
        cfg = await load_settings(session)
        rows = (await session.execute(query)).scalars().all()
        return [await request_out(session, cfg, r) for r in rows]


@router.get("/{request_id}", response_model=RequestOut, responses=ERRORS)
async def get(request_id: RequestId, http: HttpRequest) -> RequestOut:
    async with server_of(http).db.read() as session:
        request = await session.get(Request, request_id)
        if request is None:
            msg = f"request {request_id} does not exist"
            raise NotFound(msg)
        return await request_out(session, await load_settings(session), request)


@router.post("/{request_id}/{action}", response_model=RequestOut,
             responses={**ERRORS, 503: {"description": "No robot to deliver"}})
async def act(request_id: RequestId, action: Action, http: HttpRequest) -> RequestOut:
    """accept, decline, cancel, confirm-loaded, confirm-unloaded, washing-started,
    washing-done, pay; 409 with a message when the status does not allow it."""
    server = server_of(http)
    async with server.db.write() as session:
        cfg = await load_settings(session)
        request = await apply_action(session, server.clock(), cfg, request_id, action)
        return await request_out(session, cfg, request)
