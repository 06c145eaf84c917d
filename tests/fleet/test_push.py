"""Push (issue 27): Server-Sent Events (GET /api/events) deliver the notifications as they are
created, a customer only its own, the staff all; webhooks POST each one, with bounded retries,
never holding a request up. Served by uvicorn on 127.0.0.1 on the test's own loop."""

from __future__ import annotations

import asyncio
import contextlib
import json
import socket
import time
from collections.abc import AsyncIterator
from typing import Any

import httpx
import pytest
import uvicorn
from fleet_harness import bearer, token_for
from starlette.types import Receive, Scope, Send


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port: int = sock.getsockname()[1]
        return port


@contextlib.asynccontextmanager
async def serving(app: Any) -> AsyncIterator[str]:
    """``app`` served by uvicorn on 127.0.0.1 (its lifespan is the test's business)."""
    port = _free_port()
    server = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=port, lifespan="off",
                                           log_config=None, timeout_graceful_shutdown=1))
    task = asyncio.create_task(server.serve())
    while not server.started:
        assert not task.done(), "uvicorn did not start"
        await asyncio.sleep(0.01)
    try:
        yield f"http://127.0.0.1:{port}"
    finally:
        server.should_exit = True
        await task


class Listener:
    """An SSE client: the events (kind, data) in order, each with when it came."""

    def __init__(self, url: str, token: str, last_event_id: str | None = None) -> None:
        self.url = url
        self.token = token
        self.headers = bearer(token) | (
            {"Last-Event-ID": last_event_id} if last_event_id is not None else {})
        self.events: asyncio.Queue[tuple[float, str, dict[str, Any]]] = asyncio.Queue()
        self.subscribed = asyncio.Event()
        self.status: int | None = None
        self._task: asyncio.Task[None] | None = None

    async def __aenter__(self) -> Listener:
        self._task = asyncio.create_task(self._listen())
        await asyncio.wait_for(self.subscribed.wait(), 5)
        return self

    async def __aexit__(self, *exc: object) -> None:
        assert self._task is not None
        self._task.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await self._task

    async def _listen(self) -> None:
        async with httpx.AsyncClient(timeout=None) as client, client.stream(
                "GET", f"{self.url}/api/events", headers=self.headers) as response:
            self.status = response.status_code
            assert response.headers["content-type"].startswith("text/event-stream")
            kind = ""
            async for line in response.aiter_lines():
                if line.startswith(": subscribed"):
                    self.subscribed.set()
                elif line.startswith("event: "):
                    kind = line[len("event: "):]
                elif line.startswith("data: "):
                    self.events.put_nowait((time.monotonic(), kind,
                                            json.loads(line[len("data: "):])))

    async def next(self, timeout_s: float = 3.0) -> tuple[float, str, dict[str, Any]]:
        return await asyncio.wait_for(self.events.get(), timeout_s)


CUSTOMER_1 = token_for("customer", "1")
STAFF = token_for("admin", "staff")


class TestServerSentEvents:
    async def test_a_customer_gets_its_request_status_change_within_a_second(self, fleet):
        """The robot arrives at customer 1's room: customer 1's stream has the notice within
        1 s of the change; customer 2's request's notices never reach it."""
        mine = await fleet.request(1)
        async with serving(fleet.app) as url, Listener(url, CUSTOMER_1) as listener:
            await fleet.request(2)  # customer 2's: not for customer 1
            await fleet.arrive_at_room("robot-1", 1)
            changed = time.monotonic()
            assert await fleet.status(mine["Id"]) == "ArrivedAtRoom"
            came, kind, data = await listener.next()
            assert (kind, data["Kind"], data["RequestId"], data["CustomerId"]) == (
                "robot.arrived", "robot.arrived", mine["Id"], 1)
            assert came - changed < 1.0
            assert listener.events.empty()

    async def test_the_staff_get_every_notification_in_order(self, fleet):
        async with serving(fleet.app) as url, Listener(url, STAFF) as listener:
            first = await fleet.request(1)
            second = await fleet.request(2)
            seen = [await listener.next() for _ in range(2)]
            assert [(d["Kind"], d["RequestId"]) for _, _, d in seen] == [
                ("request.accepted", first["Id"]), ("request.accepted", second["Id"])]
            ids = [d["Id"] for _, _, d in seen]
            assert ids == sorted(ids)

    async def test_another_server_process_notifications_come_too(self, make_fleet):
        """Behind a load balancer: a change made through the other server reaches this
        one's listeners (its hub polls the table every second)."""
        here = await make_fleet()
        there = await make_fleet()
        async with serving(here.app) as url, Listener(url, CUSTOMER_1) as listener:
            started = time.monotonic()
            body = await there.request(1)
            came, kind, data = await listener.next()
            assert (kind, data["RequestId"]) == ("request.accepted", body["Id"])
            assert came - started < 2.5

    async def test_a_stream_resumed_after_its_last_event_id_misses_nothing(self, fleet):
        """A stream that reconnects with Last-Event-ID gets every notification after that id
        that it may see, once and in id order, then the new ones as they come."""
        made = [await fleet.request(c) for c in (1, 2, 3)]
        async with serving(fleet.app) as url, httpx.AsyncClient() as client:
            stored = (await client.get(f"{url}/api/notifications?limit=100",
                                       headers=bearer(STAFF))).json()
            ids = sorted(n["Id"] for n in stored)
            async with Listener(url, STAFF, last_event_id=str(ids[0])) as listener:
                missed = [(await listener.next())[2]["Id"] for _ in ids[1:]]
                assert missed == ids[1:]
                await fleet.do(made[0]["Id"], "cancel")
                _, kind, live = await listener.next()
                assert (kind, live["RequestId"]) == ("request.cancelled", made[0]["Id"])
                assert listener.events.empty()
            async with Listener(url, CUSTOMER_1, last_event_id="0") as mine:
                _, _, first = await mine.next()
                _, _, second = await mine.next()
                assert [first["Kind"], second["Kind"]] == ["request.accepted",
                                                           "request.cancelled"]
                assert {first["CustomerId"], second["CustomerId"]} == {1}
                assert mine.events.empty()

    async def test_a_last_event_id_that_is_not_an_id_is_422(self, fleet):
        async with serving(fleet.app) as url, httpx.AsyncClient() as client:
            answer = await client.get(f"{url}/api/events",
                                      headers=bearer(STAFF) | {"Last-Event-ID": "abc"})
            assert answer.status_code == 422
            assert "Last-Event-ID" in answer.json()["detail"]

    async def test_robots_may_not_listen_and_no_token_is_401(self, fleet):
        async with serving(fleet.app) as url, httpx.AsyncClient() as client:
            robot = await client.get(f"{url}/api/events",
                                     headers=bearer(token_for("robot", "robot-1")))
            assert robot.status_code == 403
            assert (await client.get(f"{url}/api/events")).status_code == 401

    async def test_stopping_the_server_ends_the_streams(self, fleet):
        async with serving(fleet.app) as url, Listener(url, STAFF) as listener:
            await fleet.server.events.stop()
            assert listener._task is not None
            await asyncio.wait_for(listener._task, 3)


class Receiver:
    """A webhook receiver: answers the first ``fail`` POSTs 500 (or waits ``hang_s``), then
    204; keeps the bodies of the ones it accepted."""

    def __init__(self, fail: int = 0, hang_s: float = 0.0) -> None:
        self.fail = fail
        self.hang_s = hang_s
        self.calls = 0
        self.bodies: asyncio.Queue[dict[str, Any]] = asyncio.Queue()

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        assert scope["type"] == "http"
        body = b""
        while True:
            message = await receive()
            body += message.get("body", b"")
            if not message.get("more_body"):
                break
        self.calls += 1
        if self.hang_s:
            await asyncio.sleep(self.hang_s)
        status = 500 if self.calls <= self.fail else 204
        if status == 204:
            self.bodies.put_nowait(json.loads(body))
        await send({"type": "http.response.start", "status": status, "headers": []})
        await send({"type": "http.response.body", "body": b""})


class TestWebhooks:
    async def test_each_notification_is_posted_as_json(self, fleet):
        receiver = Receiver()
        async with serving(receiver) as url:
            await fleet.settings(WebhookUrls=[f"{url}/hook"])
            body = await fleet.request(1)
            posted = await asyncio.wait_for(receiver.bodies.get(), 3)
            assert (posted["Kind"], posted["RequestId"], posted["Recipient"]) == (
                "request.accepted", body["Id"], "customer")
            assert set(posted) == {"Id", "CreatedAt", "Recipient", "Level", "Kind", "Message",
                                   "CustomerId", "RequestId", "RobotName"}

    async def test_a_failing_receiver_is_retried_a_bounded_number_of_times(self, fleet):
        receiver = Receiver(fail=2)
        async with serving(receiver) as url:
            await fleet.settings(WebhookUrls=[f"{url}/hook"], WebhookRetries=2)
            request = await fleet.request(1)
            await asyncio.wait_for(receiver.bodies.get(), 5)
            assert receiver.calls == 3
        dead = Receiver(fail=100)
        async with serving(dead) as url:
            await fleet.settings(WebhookUrls=[f"{url}/hook"], WebhookRetries=1)
            await fleet.do(request["Id"], "cancel")
            for _ in range(100):
                if fleet.server.webhooks.failed:
                    break
                await asyncio.sleep(0.05)
            assert (fleet.server.webhooks.failed, dead.calls) == (1, 2)

    async def test_a_slow_receiver_never_holds_a_request_up(self, fleet):
        receiver = Receiver(hang_s=5)
        async with serving(receiver) as url:
            await fleet.settings(WebhookUrls=[f"{url}/hook"], WebhookTimeoutS=0.2,
                                 WebhookRetries=0)
            started = time.monotonic()
            await fleet.request(1)
            assert time.monotonic() - started < 0.5
            for _ in range(100):
                if fleet.server.webhooks.failed:
                    break
                await asyncio.sleep(0.05)
            assert fleet.server.webhooks.failed == 1

    @pytest.mark.parametrize("urls", [["ftp://x"], ["not a url"], ["http://x"] * 11, "http://x"])
    async def test_bad_urls_are_422(self, fleet, urls):
        response = await fleet.http.put("/api/settings", json={"WebhookUrls": urls})
        assert response.status_code == 422
        assert "WebhookUrls" in response.text
