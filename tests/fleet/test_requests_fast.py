"""The request reads' fast path (fleet.api.requests_fast) answers exactly as the FastAPI routes
do, in every state the requests reach, and leaves everything it does not answer to the app."""

from __future__ import annotations

import asyncio
import functools
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any

import httpx
import pytest
import uvicorn
from fastapi import FastAPI
from fleet_harness import Fleet, bearer, token_for
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.stateful import invariant
from sqlalchemy import select
from test_properties import FleetMachine

from fleet.api.auth import SCOPE_KEY, Authenticate
from fleet.api.deps import request_out
from fleet.api.request_reads import newest_requests, one_request
from fleet.api.requests_fast import RequestsFastPath
from fleet.http_protocol import CoalescingHttpToolsProtocol
from fleet.models import Request
from fleet.settings import load_settings
from fleet.tokens import Principal, Role

Answer = tuple[int, list[tuple[bytes, bytes]], bytes]
CALLERS: dict[str, dict[str, str]] = {
    "admin": bearer(token_for("admin", "staff")),
    **{f"customer {c}": bearer(token_for("customer", str(c))) for c in range(1, 6)},
    "robot": bearer(token_for("robot", "robot-1")),
    "unknown token": bearer("not-a-token-of-this-site-0123456789"),
    "no token": {},
}
# Ids in the route's range, out of it, and spelled in ways only the route reads.
ODD_IDS = ["0", "2147483647", "2147483648", "99999999999", "007", "+1", "-1", "1.0", "x",
           "%201", "1%20", "1/", "", "1e3", "\u0661"]


def routed(fleet: Fleet) -> httpx.AsyncClient:
    """A client of the same app with only authentication in front of FastAPI: every request
    is answered by the routes."""
    app = Authenticate(functools.partial(FastAPI.__call__, fleet.app), fleet.server.auth)
    return httpx.AsyncClient(transport=httpx.ASGITransport(app=app), base_url="http://fleet")


def direct(fleet: Fleet) -> httpx.AsyncClient:
    return httpx.AsyncClient(transport=httpx.ASGITransport(app=fleet.app),
                             base_url="http://fleet")


async def answer(client: httpx.AsyncClient, path: str, headers: dict[str, str]) -> Answer:
    response = await client.get(path, headers=headers)
    return response.status_code, response.headers.raw, response.content


async def both(fleet: Fleet, path: str, headers: dict[str, str]) -> tuple[Answer, Answer]:
    async with direct(fleet) as fast, routed(fleet) as route:
        return await answer(fast, path, headers), await answer(route, path, headers)


async def same_answers(fleet: Fleet, request_ids: list[int]) -> None:
    """Every caller, the list and each request (and some that do not exist) answer the same."""
    paths = ["/api/requests", *(f"/api/requests/{i}" for i in [*request_ids, 1, 2, 3, 500])]
    async with direct(fleet) as fast, routed(fleet) as route:
        for who, headers in CALLERS.items():
            for path in paths:
                assert await answer(fast, path, headers) == await answer(route, path, headers), \
                    (who, path)


async def same_as_the_orm(fleet: Fleet) -> None:
    """The reads (one Core query) show each request as the ORM objects do (``request_out``,
    which creating and acting on a request answer with)."""
    admin = Principal(1, Role.ADMIN, "staff")
    listed = await newest_requests(fleet.server, admin, limit=1000)
    async with fleet.server.db.read() as session:
        cfg = await load_settings(session)
        rows = (await session.execute(select(Request).order_by(Request.id.desc()))).scalars()
        expected = [await request_out(session, cfg, r) for r in rows]
    assert listed == expected
    for request in expected:
        assert await one_request(fleet.server, admin, request.Id) == request


class ReadsMachine(FleetMachine):
    """Customers, admins and robots in any order; after each step every read is answered by
    the fast path as by the route, and shows what the ORM objects show."""

    @invariant()
    def reads_answer_as_the_routes_do(self) -> None:
        self.run(same_answers(self.fleet, self.request_ids))
        self.run(same_as_the_orm(self.fleet))

    def teardown(self) -> None:
        self.run(self.fleet.__aexit__(None, None, None))
        self.loop.close()
        self.dir.cleanup()


ReadsMachine.TestCase.settings = settings(
    max_examples=8, stateful_step_count=20, deadline=None,
    suppress_health_check=[HealthCheck.too_slow])
TestReadsInEveryState = ReadsMachine.TestCase


class TestSameAnswersAsTheRoutes:
    async def test_requests_of_several_customers_in_several_statuses(self, fleet):
        """A pending, an accepted, a cancelled request and one of a customer without beacon."""
        ids = [(await fleet.request(c))["Id"] for c in (1, 2, 3, 5)]
        await fleet.act(ids[2], "cancel")
        await same_answers(fleet, ids)
        await same_as_the_orm(fleet)

    async def test_no_requests_at_all(self, fleet):
        await same_answers(fleet, [])

    @pytest.mark.parametrize("text", ODD_IDS)
    async def test_ids_the_fast_path_leaves_to_the_route(self, fleet, text):
        await fleet.request(1)
        for headers in (CALLERS["admin"], CALLERS["customer 1"], CALLERS["robot"]):
            fast, route = await both(fleet, f"/api/requests/{text}", headers)
            assert fast == route, text

    @given(request_id=st.integers(-5, 2**32), caller=st.sampled_from(sorted(CALLERS)))
    @settings(max_examples=60, deadline=None,
              suppress_health_check=[HealthCheck.function_scoped_fixture])
    async def test_any_id_and_caller(self, fleet, request_id, caller):
        if not (await fleet.http.get("/api/requests")).json():
            await fleet.request(1)
            await fleet.request(2)
        fast, route = await both(fleet, f"/api/requests/{request_id}", CALLERS[caller])
        assert fast == route

    async def test_a_query_string_is_the_routes(self, fleet):
        """Queries go to the route, which reads them (a customer filtering on another's id
        gets 403)."""
        await fleet.request(1)
        fast, route = await both(fleet, "/api/requests?customer_id=2", CALLERS["customer 1"])
        assert fast == route
        assert fast[0] == 403


@asynccontextmanager
async def served(fleet: Fleet) -> AsyncIterator[str]:
    """The fleet app under uvicorn on a free local port, as ``robotd-fleet serve`` runs it."""
    config = uvicorn.Config(fleet.app, host="127.0.0.1", port=0, log_config=None,
                            access_log=False, lifespan="off", http=CoalescingHttpToolsProtocol)
    server = uvicorn.Server(config)
    task = asyncio.ensure_future(server.serve())
    try:
        while not server.started:
            assert not task.done(), "uvicorn did not start"
            await asyncio.sleep(0.01)
        port = server.servers[0].sockets[0].getsockname()[1]
        yield f"http://127.0.0.1:{port}"
    finally:
        server.should_exit = True
        await task


class TestOverTcp:
    async def test_a_client_over_tcp_gets_the_routes_answers(self, fleet):
        """Under uvicorn, the fast path's status, content type, length and body are the
        routes' (uvicorn adds its date and server headers to both)."""
        ids = [(await fleet.request(c))["Id"] for c in (1, 2)]
        await fleet.act(ids[1], "cancel")
        paths = ["/api/requests", *(f"/api/requests/{i}" for i in [*ids, 9, 0])]
        async with served(fleet) as url, httpx.AsyncClient(base_url=url) as tcp, \
                routed(fleet) as route:
            for who in ("admin", "customer 1", "customer 2", "robot", "no token"):
                for path in paths:
                    got = await tcp.get(path, headers=CALLERS[who])
                    want = await route.get(path, headers=CALLERS[who])
                    assert (got.status_code, got.headers.get("content-type"),
                            got.headers.get("content-length"), got.content) == \
                        (want.status_code, want.headers.get("content-type"),
                         want.headers.get("content-length"), want.content), (who, path)


class RecordingApp:
    """The app behind the middleware: records the paths that reached it and answers 418."""

    def __init__(self) -> None:
        self.paths: list[str] = []

    async def __call__(self, scope, receive, send) -> None:
        self.paths.append(scope["path"])
        await send({"type": "http.response.start", "status": 418, "headers": []})
        await send({"type": "http.response.body", "body": b""})


async def call(app, path: str, *, method: str = "GET", query: bytes = b"",
               role: Role | None = Role.ADMIN, root_path: str = "") -> int:
    sent: list[dict[str, Any]] = []

    async def receive() -> dict[str, Any]:
        return {"type": "http.request", "body": b"", "more_body": False}

    async def send(message: dict[str, Any]) -> None:
        sent.append(message)

    scope: dict[str, Any] = {"type": "http", "method": method, "path": path,
                             "root_path": root_path, "headers": [], "query_string": query}
    if role is not None:
        scope[SCOPE_KEY] = Principal(1, role, "1" if role == Role.CUSTOMER else "staff")
    await app(scope, receive, send)
    status: int = sent[0]["status"]
    return status


class TestWhatTheFastPathTakes:
    @pytest.mark.parametrize("path", ["/api/requests", "/api/requests/1", "/api/requests/77"])
    @pytest.mark.parametrize("role", [Role.ADMIN, Role.CUSTOMER])
    async def test_plain_reads_never_reach_the_app(self, fleet, path, role):
        await fleet.request(1)
        inner = RecordingApp()
        status = await call(RequestsFastPath(inner, fleet.server), path, role=role)
        assert status in (200, 404)
        assert inner.paths == []

    @pytest.mark.parametrize(("what", "path", "kwargs"), [
        ("a POST", "/api/requests", {"method": "POST"}),
        ("a HEAD", "/api/requests/1", {"method": "HEAD"}),
        ("a query", "/api/requests", {"query": b"limit=5"}),
        ("a robot", "/api/requests/1", {"role": Role.ROBOT}),
        ("no caller", "/api/requests/1", {"role": None}),
        ("a root path", "/api/requests/1", {"root_path": "/fleet"}),
        ("a trailing slash", "/api/requests/", {}),
        ("an action", "/api/requests/1/cancel", {}),
        ("a leading zero", "/api/requests/01", {}),
        ("an id past the range", "/api/requests/2147483648", {}),
        ("another path", "/api/robots", {}),
    ], ids=lambda v: v if isinstance(v, str) else "")
    async def test_everything_else_reaches_the_app(self, fleet, what, path, kwargs):
        inner = RecordingApp()
        status = await call(RequestsFastPath(inner, fleet.server), path, **kwargs)
        assert status == 418, what
        assert inner.paths == [path]
