"""Who may call what: every operation refuses anonymous, unknown, revoked and wrong-role
tokens (401/403) without changing anything; customers and robots reach only their own."""

from __future__ import annotations

import re
from typing import Any

import httpx
import pytest
from fleet_harness import Fleet, bearer, token_for
from sqlalchemy import select

from fleet.models import Base

ADMIN = token_for("admin", "staff")
ROBOT_1 = token_for("robot", "robot-1")
ROBOT_2 = token_for("robot", "robot-2")
CUSTOMER_1 = token_for("customer", "1")
CUSTOMER_2 = token_for("customer", "2")

# Who may call each operation (docs/fleet.md has the same table).
ROBOT_OPS = {("post", "/api/Robot/{RobotName}/data-exchange"),
             ("post", "/api/Robot/{RobotName}/status")}
CUSTOMER_OPS = {("post", "/api/requests"), ("get", "/api/requests"),
                ("get", "/api/requests/{request_id}"),
                ("post", "/api/requests/{request_id}/{action}"), ("get", "/api/events")}
PUBLIC_OPS = {("get", "/health")}
PATH_VALUES = {"RobotName": "robot-1", "request_id": "1", "action": "cancel",
               "name": "robot-1", "token_id": "1", "alert_id": "1"}


async def dump(fleet: Fleet) -> dict[str, list[tuple[Any, ...]]]:
    """Every row of every table, in a comparable form."""
    await fleet.server.flush_pings()
    tables: dict[str, list[tuple[Any, ...]]] = {}
    async with fleet.server.db.read_connection() as conn:
        for name, table in Base.metadata.tables.items():
            rows = (await conn.execute(select(table))).all()
            tables[name] = sorted(tuple(map(repr, row)) for row in rows)
    return tables


async def operations(fleet: Fleet) -> list[tuple[str, str, str]]:
    """(method, path template, concrete path) of every operation in the OpenAPI document."""
    document = (await fleet.http.get("/openapi.json")).json()
    found = []
    for template, item in document["paths"].items():
        concrete = re.sub(r"\{(\w+)\}", lambda m: PATH_VALUES[m.group(1)], template)
        for method in item:
            found.append((method, template, concrete))
    return found


async def call(fleet: Fleet, method: str, path: str, token: str | None) -> httpx.Response:
    """One call with a plausible body; ``token`` None: with no Authorization header at all
    (the harness client would add the admin's)."""
    body = {"CustomerId": 1} if method in ("post", "put", "patch") else None
    if token is None:
        async with httpx.AsyncClient(transport=httpx.ASGITransport(app=fleet.app),
                                     base_url="http://fleet") as anonymous:
            return await anonymous.request(method.upper(), path, json=body)
    return await fleet.http.request(method.upper(), path, json=body, headers=bearer(token))


@pytest.fixture
async def fleet(make_fleet: Any) -> Fleet:
    """A fleet where customer 1 has request 1 (served by robot-1)."""
    fleet: Fleet = await make_fleet()
    await fleet.request(1)
    return fleet


class TestEveryOperation:
    async def test_anonymous_unknown_and_revoked_tokens_get_401_and_change_nothing(
            self, fleet):
        """Each operation but /health answers 401 with WWW-Authenticate: Bearer to no token,
        a malformed header, an unknown token and a revoked one; the database is unchanged."""
        revoked = (await fleet.http.post("/api/tokens", json={
            "Role": "customer", "Subject": "1"})).json()
        assert (await fleet.http.delete(f"/api/tokens/{revoked['Id']}")).status_code == 200
        ops = await operations(fleet)
        assert len(ops) >= 18
        before = await dump(fleet)
        for method, template, path in ops:
            if (method, template) in PUBLIC_OPS:
                continue
            for token in (None, "x" * 43, revoked["Token"]):
                response = await call(fleet, method, path, token)
                assert response.status_code == 401, (method, path, token, response.text)
                assert response.headers["www-authenticate"].startswith("Bearer")
                assert response.json()["detail"]
            malformed = await fleet.http.request(
                method.upper(), path, headers={"Authorization": f"Basic {ADMIN}"})
            assert malformed.status_code == 401, (method, path)
        assert await dump(fleet) == before

    async def test_wrong_role_tokens_get_403_and_change_nothing(self, fleet):
        """A robot token on anything but its exchange and status, a customer token on admin
        operations, an admin token on a robot's exchange or status: 403, nothing changed."""
        before = await dump(fleet)
        checked = 0
        for method, template, path in await operations(fleet):
            op = (method, template)
            if op in PUBLIC_OPS:
                continue
            refused = [ROBOT_1] if op not in ROBOT_OPS else [ADMIN, CUSTOMER_1]
            if op not in ROBOT_OPS and op not in CUSTOMER_OPS:
                refused.append(CUSTOMER_1)
            for token in refused:
                response = await call(fleet, method, path, token)
                assert response.status_code == 403, (method, path, token, response.text)
                assert response.json()["detail"]
                checked += 1
        assert checked >= 25
        assert await dump(fleet) == before

    async def test_the_document_declares_bearer_security_on_every_operation(self, fleet):
        document = (await fleet.http.get("/openapi.json")).json()
        schemes = document["components"]["securitySchemes"]
        assert schemes["BearerToken"] == {
            "type": "http", "scheme": "bearer",
            "description": schemes["BearerToken"]["description"]}
        for method, template, _ in await operations(fleet):
            operation = document["paths"][template][method]
            if (method, template) in PUBLIC_OPS:
                assert "security" not in operation
                continue
            assert operation["security"] == [{"BearerToken": []}], (method, template)
            for code in ("401", "403", "422", "429"):
                assert code in operation["responses"], (method, template, code)


class TestOwners:
    async def test_a_customer_cannot_touch_another_customers_request(self, fleet):
        """Customer 2 can neither read, cancel, confirm nor pay customer 1's request, nor
        create one in its name, nor list its requests; nothing changes."""
        before = await dump(fleet)
        theirs = bearer(CUSTOMER_2)
        assert (await fleet.http.get("/api/requests/1", headers=theirs)).status_code == 403
        for action in ("cancel", "confirm-loaded", "confirm-unloaded", "pay"):
            response = await fleet.http.post(f"/api/requests/1/{action}", headers=theirs)
            assert response.status_code == 403, action
            assert "another customer" in response.json()["detail"]
        response = await fleet.http.post("/api/requests", json={"CustomerId": 1},
                                         headers=theirs)
        assert response.status_code == 403
        listed = await fleet.http.get("/api/requests?customer_id=1", headers=theirs)
        assert listed.status_code == 403
        assert (await fleet.http.get("/api/requests", headers=theirs)).json() == []
        assert await dump(fleet) == before

    async def test_a_customer_reaches_its_own_request_but_not_staff_actions(self, fleet):
        own = bearer(CUSTOMER_1)
        assert (await fleet.http.get("/api/requests/1", headers=own)).status_code == 200
        assert [r["Id"] for r in (await fleet.http.get("/api/requests", headers=own)).json()] \
            == [1]
        for action in ("accept", "decline", "washing-started", "washing-done"):
            response = await fleet.http.post(f"/api/requests/1/{action}", headers=own)
            assert response.status_code == 403, action
        cancelled = await fleet.http.post("/api/requests/1/cancel", headers=own)
        assert cancelled.status_code == 200
        assert cancelled.json()["Status"] == "Cancelled"

    async def test_a_robot_cannot_post_as_another_robot(self, fleet):
        """robot-2 reporting an arrival on robot-1's path: 403, robot-1's request unmoved."""
        before = await dump(fleet)
        response = await fleet.http.post(
            "/api/Robot/robot-1/data-exchange", headers=bearer(ROBOT_2),
            json={"IsInTarget": True, "WeightKg": 3.0, "DetectedBeacons": [
                {"MacAddress": "C3:00:00:00:01:01", "Rssi": -40}]})
        assert response.status_code == 403
        assert "robot-1" in response.json()["detail"]
        assert await dump(fleet) == before
        assert await fleet.status(1) == "Accepted"


class TestTokens:
    async def test_tokens_are_stored_only_as_hashes(self, fleet):
        issued = (await fleet.http.post("/api/tokens", json={
            "Role": "robot", "Subject": "robot-2"})).json()
        tables = await dump(fleet)
        assert issued["Token"] not in repr(tables)
        assert ROBOT_1 not in repr(tables)
        listed = (await fleet.http.get("/api/tokens")).json()
        assert all("Token" not in t for t in listed)
        reply = await fleet.http.post("/api/Robot/robot-2/data-exchange", json={},
                                      headers=bearer(issued["Token"]))
        assert reply.status_code == 200

    async def test_a_revoked_token_is_refused_at_once(self, fleet):
        issued = (await fleet.http.post("/api/tokens", json={
            "Role": "customer", "Subject": "2"})).json()
        own = bearer(issued["Token"])
        assert (await fleet.http.get("/api/requests", headers=own)).status_code == 200
        await fleet.http.delete(f"/api/tokens/{issued['Id']}")
        assert (await fleet.http.get("/api/requests", headers=own)).status_code == 401

    async def test_a_token_for_an_unknown_robot_is_refused(self, fleet):
        response = await fleet.http.post("/api/tokens", json={"Role": "robot",
                                                              "Subject": "robot-9"})
        assert response.status_code == 404


class TestBruteForce:
    async def test_the_client_gets_429_after_n_failures_a_minute(self, db_url):
        """Five failed authentications from one address, then 429 with Retry-After, even
        for a valid token (a guess that hits must not be told apart); nothing changes."""
        async with Fleet(db_url, auth_failures_per_min=5) as fleet:
            before = await dump(fleet)
            for _ in range(5):
                response = await fleet.http.get("/api/robots", headers=bearer("y" * 43))
                assert response.status_code == 401
            for token in ("y" * 43, ADMIN):
                response = await fleet.http.get("/api/robots", headers=bearer(token))
                assert response.status_code == 429
                assert 1 <= int(response.headers["retry-after"]) <= 60
                assert "too many failed authentications" in response.json()["detail"]
            assert await dump(fleet) == before
            assert (await fleet.http.get("/health")).status_code == 200


class TestFailureLimiter:
    def test_failures_leave_the_window_after_a_minute(self):
        from fleet.ratelimit import FailureLimiter

        now = [0.0]
        limiter = FailureLimiter(3, lambda: now[0])
        for t in (0.0, 10.0, 20.0):
            now[0] = t
            assert limiter.retry_after_s("a") == 0
            limiter.failed("a")
        assert limiter.retry_after_s("a") == 40
        assert limiter.retry_after_s("b") == 0
        now[0] = 60.0
        assert limiter.retry_after_s("a") == 0  # the first failure has left the window


class TestRevokedElsewhere:
    async def test_a_token_revoked_by_another_process_is_refused_within_the_ttl(self, fleet):
        """A revocation this process did not make (CLI, another server) is seen once the
        token snapshot is older than its TTL."""
        import asyncio

        from fleet.auth import Authenticator
        from fleet.tokens import revoke

        auth = Authenticator(fleet.server.db, ttl_s=0.05)
        principal = await auth.principal(CUSTOMER_1)
        assert principal is not None
        async with fleet.server.db.write(serial=False) as session:
            await revoke(session, fleet.clock(), principal.token_id)
        await asyncio.sleep(0.06)
        assert await auth.principal(CUSTOMER_1) is None
