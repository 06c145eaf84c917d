"""The laundry actors' polls: sent straight to the transport, they get what the client's
``send`` gets from the in-process fleet."""

from __future__ import annotations

from collections.abc import AsyncIterator
from datetime import UTC, datetime
from pathlib import Path

import httpx
import pytest

from fleet.site import parse_site
from sim.robots.laundry.actors import InProcessFleet, send_poll

SITE = """
[[rooms]]
name = "base"

[[rooms]]
name = "101"

[[beacons]]
mac = "C0:FF:EE:00:00:01"
name = "base"
room = "base"
base = true

[[beacons]]
mac = "C0:FF:EE:00:01:01"
name = "room-101"
room = "101"

[[customers]]
id = 1
name = "Ana"
beacon = "C0:FF:EE:00:01:01"

[[customers]]
id = 2
name = "Ben"
beacon = "C0:FF:EE:00:01:01"

[[robots]]
name = "laundry-1"
"""


@pytest.fixture
async def fleet(tmp_path: Path) -> AsyncIterator[InProcessFleet]:
    fleet = InProcessFleet(tmp_path, parse_site(SITE, "site"), {"AutoAccept": True},
                           datetime(2026, 1, 5, 8, 0, tzinfo=UTC))
    await fleet.start()
    yield fleet
    await fleet.close()


def same(a: httpx.Response, b: httpx.Response) -> None:
    assert (a.status_code, a.headers.raw, a.content) == (b.status_code, b.headers.raw, b.content)


class TestSendPoll:
    async def test_the_polls_get_the_clients_answers(self, fleet):
        """The staff's list and each customer's request, before and after requests exist,
        another customer's (403) and an unknown one (404): status, raw headers and bytes."""
        staff, ana, ben = fleet.client, fleet.customer_client(1), fleet.customer_client(2)
        polls = [(staff, "/api/requests"), (ana, "/api/requests/1"), (ben, "/api/requests/1"),
                 (staff, "/api/requests/99"), (ana, "/api/requests")]
        robot = httpx.AsyncClient(transport=fleet.transport, base_url="http://fleet.sim",
                                  headers={"Authorization": "Bearer "
                                           + fleet.robot_token_file("laundry-1").read_text()
                                           .strip()})
        # A robot is assignable once it has reported (issue 27: online means reported).
        assert (await robot.post("/api/Robot/laundry-1/data-exchange",
                                 json={"RobotName": "laundry-1"})).status_code == 200
        await robot.aclose()
        for created in (False, True):
            if created:
                assert (await ana.post("/api/requests", json={"CustomerId": 1})).status_code \
                    == 201
            for client, path in polls:
                request = client.build_request("GET", path)
                same(await client.send(request), await send_poll(fleet.transport, request))

    async def test_a_poll_can_be_sent_again(self, fleet):
        """The actors build each poll once and send it every second."""
        request = fleet.client.build_request("GET", "/api/requests")
        first = await send_poll(fleet.transport, request)
        same(first, await send_poll(fleet.transport, request))
        assert first.json() == []
