"""Server-Sent Events: the notifications as they are created (issue 27)."""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator
from typing import Annotated, Any

from fastapi import APIRouter, Header, Query
from fastapi import Request as HttpRequest
from fastapi.responses import StreamingResponse

from fleet.api.auth import CustomerOrAdmin
from fleet.api.deps import AUTH_ERRORS, server_of
from fleet.errors import Invalid
from fleet.push import Filter, Pushed, StaffEvent
from fleet.tokens import Principal, Role

router = APIRouter(prefix="/api", tags=["events"], responses=AUTH_ERRORS)

KEEPALIVE_S = 15.0
"""A comment line this often keeps proxies from closing a quiet stream."""

_STREAM: dict[int | str, dict[str, Any]] = {200: {"description": (
    "text/event-stream: one event per notification (`id`: its Id, `event`: its Kind, "
    "`data`: the notification as JSON, as in GET /api/notifications); comment lines "
    "(`: ...`) when subscribed and every 15 s"),
    "content": {"text/event-stream": {"schema": {"type": "string"}}}}}


@router.get("/events", response_class=StreamingResponse, responses=_STREAM)
async def events(
    http: HttpRequest, caller: CustomerOrAdmin,
    robots: Annotated[bool, Query(description=(
        "staff only: also `event: robots` whenever a robot's state, place or fault "
        "changes (the console's site map)"))] = False,
    requests: Annotated[bool, Query(description=(
        "customers only: also `event: request` whenever one of the caller's requests "
        "changes status (the console's phone page)"))] = False,
    last_event_id: Annotated[str | None, Header(
        alias="Last-Event-ID", description=(
            "a reconnecting stream: the id of the last event it got; the stream starts with "
            "every notification after it, in order"))] = None,
) -> StreamingResponse:
    """Notifications pushed as they are created, from the subscription on: a customer gets
    its own (those addressed to it), the staff all. With `Last-Event-ID` (what an
    EventSource sends when it reconnects) it starts after that id instead, so that nothing is
    missed or repeated; a stream more than 1000 events behind is ended (GET
    /api/notifications has them all)."""
    after_id = _event_id(last_event_id)
    return StreamingResponse(
        _stream(http, _filter(caller), after_id, staff=robots and caller.role == Role.ADMIN,
                customer_id=caller.customer_id if requests and caller.role == Role.CUSTOMER
                else None),
        media_type="text/event-stream",
        headers={"Cache-Control": "no-cache", "X-Accel-Buffering": "no"})


def _event_id(header: str | None) -> int | None:
    if header is None or not header.strip():
        return None
    text = header.strip()
    if not (text.isascii() and text.isdigit()) or len(text) > 18:
        msg = f"Last-Event-ID: expected the id of a notification (a whole number), got {text!r}"
        raise Invalid(msg)
    return int(text)


def _filter(caller: Principal) -> Filter:
    if caller.role == Role.ADMIN:
        return lambda _n: True
    customer_id = caller.customer_id
    return lambda n: n.Recipient == "customer" and n.CustomerId == customer_id


async def _stream(http: HttpRequest, wants: Filter, after_id: int | None, *, staff: bool,
                  customer_id: int | None) -> AsyncIterator[bytes]:
    async with server_of(http).events.subscribe(wants, after_id, staff=staff,
                                                customer_id=customer_id) as queue:
        yield b": subscribed\n\n"
        while True:
            try:
                item = await asyncio.wait_for(queue.get(), KEEPALIVE_S)
            except TimeoutError:
                yield b": keepalive\n\n"
                continue
            if item is None:
                return
            yield encode(item)


def encode(item: Pushed) -> bytes:
    """One SSE event (the JSON has no newline in it, so one ``data`` line)."""
    if isinstance(item, StaffEvent):
        return f"event: {item.event}\ndata: {item.data}\n\n".encode()
    return (f"id: {item.Id}\nevent: {item.Kind}\ndata: ".encode()
            + item.model_dump_json().encode() + b"\n\n")
