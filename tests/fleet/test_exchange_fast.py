"""The data exchange's fast path (fleet.api.exchange_fast) answers exactly as the FastAPI route
does, and leaves everything it does not answer to the app."""

from __future__ import annotations

import json
from typing import Any

import pytest
from fleet_harness import ROOM_MACS, beacon, bearer, token_for

from fleet.api.auth import SCOPE_KEY
from fleet.api.exchange_fast import ExchangeFastPath
from fleet.tokens import Principal, Role

ROBOT = "robot-1"
PATH = f"/api/Robot/{ROBOT}/data-exchange"
# FastAPI reads "+json" bodies as JSON too, but the fast path takes only application/json:
# the same request with this type is answered by the route.
ROUTE_ONLY = "application/robot+json"


def report(**fields: Any) -> bytes:
    body = {"RobotName": ROBOT, "Timestamp": "2026-01-05T08:00:00Z",
            "DetectedBeacons": [beacon(ROOM_MACS[1])], "IsInTarget": False,
            "WeightKg": 0.0, "UltrasonicDistance": 80.0}
    body.update(fields)
    return json.dumps(body).encode()


async def post(fleet, body: bytes, content_type: str, path: str = PATH, **headers: str):
    response = await fleet.http.post(path, content=body,
                                     headers={"content-type": content_type, **headers})
    return response.status_code, response.headers.get("content-type"), response.content


class RecordingApp:
    """The app behind the middleware: records what reached it and answers 418."""

    def __init__(self) -> None:
        self.bodies: list[bytes] = []

    async def __call__(self, scope, receive, send) -> None:
        body = b""
        while True:
            message = await receive()
            body += message.get("body", b"")
            if not message.get("more_body"):
                break
        self.bodies.append(body)
        await send({"type": "http.response.start", "status": 418, "headers": []})
        await send({"type": "http.response.body", "body": b""})


async def call(app, body_chunks: list[bytes], *, path: str = PATH, method: str = "POST",
               content_type: bytes = b"application/json") -> tuple[int, bytes]:
    chunks = list(body_chunks)
    sent: list[dict[str, Any]] = []

    async def receive() -> dict[str, Any]:
        chunk = chunks.pop(0)
        return {"type": "http.request", "body": chunk, "more_body": bool(chunks)}

    async def send(message: dict[str, Any]) -> None:
        sent.append(message)

    scope = {"type": "http", "method": method, "path": path, "root_path": "",
             "headers": [(b"content-type", content_type)], "query_string": b"",
             SCOPE_KEY: Principal(1, Role.ROBOT, ROBOT)}
    await app(scope, receive, send)
    return sent[0]["status"], b"".join(m.get("body", b"") for m in sent[1:])


class TestSameAnswersAsTheRoute:
    @pytest.mark.parametrize(("what", "body"), [
        ("a quiet report", report()),
        ("an arrival", report(IsInTarget=True)),
        ("another robot's name", report(RobotName="robot-2")),
        # Where pydantic's JSON parser and json.loads + the model might disagree:
        ("an integer weight", report(WeightKg=2)),
        ("a fractional RSSI", report(DetectedBeacons=[{"MacAddress": "x", "Rssi": -50.0}])),
        ("a numeric flag", report(IsInTarget=1)),
        ("a numeric timestamp", report(Timestamp=1767600000)),
        ("a date-only timestamp", report(Timestamp="2026-01-05")),
        ("an unknown field", report(Colour="red")),
        ("a weight out of float range", report().replace(b'"WeightKg": 0.0', b'"WeightKg": 1e400')),
        ("a NaN weight", report().replace(b'"WeightKg": 0.0', b'"WeightKg": NaN')),
        ("a duplicated key", report().replace(b'"IsInTarget": false',
                                              b'"IsInTarget": 7, "IsInTarget": false')),
        ("a byte-order mark", b"\xef\xbb\xbf" + report()),
        ("a lone surrogate", report(RobotName="robot-1\ud800")),
        ("not UTF-8", report().replace(b"robot-1", b"robot-\xff", 1)),
        ("a JSON list", b"[]"),
        ("JSON null", b"null"),
    ], ids=lambda v: v if isinstance(v, str) else "")
    async def test_the_fast_path_and_the_route_give_the_same_bytes(self, fleet, what, body):
        """Status, content type and body are the same whichever of the two answers."""
        await fleet.request(1)
        fast = await post(fleet, body, "application/json")
        routed = await post(fleet, body, ROUTE_ONLY)
        assert fast == routed, what

    async def test_another_robots_exchange_is_403_with_the_routes_message(self, fleet):
        """robot-1's token on robot-2's path: the fast path leaves it to the route (403)."""
        path = "/api/Robot/robot-2/data-exchange"
        token = bearer(token_for("robot", ROBOT))
        fast = await post(fleet, b"{}", "application/json", path, **token)
        routed = await post(fleet, b"{}", ROUTE_ONLY, path, **token)
        assert fast == routed
        assert fast[0] == 403
        assert "robot-2" in json.loads(fast[2])["detail"]

    async def test_a_robot_removed_from_the_site_is_404(self, fleet):
        """A valid token of a robot the server no longer has: 404 on both paths."""
        async with fleet.server.db.write() as session:
            from sqlalchemy import text
            await session.execute(text("UPDATE robots SET name = 'gone' WHERE name = :n"),
                                  {"n": ROBOT})
        fast = await post(fleet, b"{}", "application/json")
        routed = await post(fleet, b"{}", ROUTE_ONLY)
        assert fast == routed
        assert fast[0] == 404

    async def test_a_wrongly_typed_field_is_named_in_the_422(self, fleet):
        """Bodies the model refuses go on to the route, whose message names the field."""
        status, _, content = await post(fleet, report(IsInTarget="yes"), "application/json")
        assert status == 422
        assert "body.IsInTarget" in json.loads(content)["detail"]

    async def test_the_route_is_still_in_the_openapi_document(self, fleet):
        document = (await fleet.http.get("/openapi.json")).json()
        operation = document["paths"]["/api/Robot/{RobotName}/data-exchange"]["post"]
        schema = operation["requestBody"]["content"]["application/json"]["schema"]
        assert schema["$ref"].endswith("/DataExchangeIn")
        assert "200" in operation["responses"]


class TestWhatTheFastPathTakes:
    async def test_a_well_formed_exchange_never_reaches_the_app(self, fleet):
        inner = RecordingApp()
        app = ExchangeFastPath(inner, server=fleet.server)
        status, content = await call(app, [report()])
        assert status == 200
        assert json.loads(content)["IsLineFollowing"] is False
        assert inner.bodies == []

    async def test_a_body_in_several_chunks_is_read_whole(self, fleet):
        inner = RecordingApp()
        app = ExchangeFastPath(inner, server=fleet.server)
        body = report()
        status, content = await call(app, [body[:10], body[10:40], body[40:]])
        assert status == 200
        assert len(json.loads(content)["ActiveBeacons"]) == 5
        assert inner.bodies == []

    @pytest.mark.parametrize(("what", "chunks", "kwargs"), [
        ("malformed JSON", [b'{"IsInTarget": tru'], {}),
        ("a string flag", [report(IsInTarget="yes")], {}),
        ("an empty body", [b""], {}),
        ("form data", [b"IsInTarget=1"], {"content_type": b"application/x-www-form-urlencoded"}),
        ("a GET", [b""], {"method": "GET"}),
        ("another path", [report()], {"path": "/api/requests"}),
        ("a trailing slash", [report()], {"path": PATH + "/"}),
        ("a control character in the name", [report()],
         {"path": "/api/Robot/robot\x01/data-exchange"}),
        ("a name too long", [report()], {"path": f"/api/Robot/{'r' * 101}/data-exchange"}),
        ("a body in two chunks that does not parse", [b'{"IsIn', b'Target": 7}'], {}),
    ], ids=lambda v: v if isinstance(v, str) else "")
    async def test_everything_else_reaches_the_app_with_its_whole_body(self, fleet, what,
                                                                       chunks, kwargs):
        inner = RecordingApp()
        app = ExchangeFastPath(inner, server=fleet.server)
        status, _ = await call(app, chunks, **kwargs)
        assert status == 418, what
        assert inner.bodies == [b"".join(chunks)]
