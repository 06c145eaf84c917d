"""The robot's 1 s data exchange against the real fleet app, over an ASGI transport."""

from __future__ import annotations

import asyncio
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import httpx

from behaviours.profiles.laundry.directive import Directive
from behaviours.profiles.laundry.fleet_link import FleetLink
from fleet.app import create_app
from fleet.clock import loop_clock
from fleet.site import parse_site
from sim import vclock

SITE = """
[[rooms]]
name = "base"
[[rooms]]
name = "101"
[[beacons]]
mac = "AA:00:00:00:00:01"
name = "base"
room = "base"
base = true
[[beacons]]
mac = "AA:00:00:00:01:01"
name = "r101"
room = "101"
[[customers]]
id = 1
name = "Ana"
beacon = "AA:00:00:00:01:01"
[[robots]]
name = "r1"
[[tokens]]
role = "robot"
subject = "r1"
token = "robot-r1-token-0123456789abcdef"
[[tokens]]
role = "customer"
subject = "1"
token = "customer-1-token-0123456789abcdef"
"""


def _report() -> dict[str, Any]:
    return {"RobotName": "r1", "Timestamp": "2026-01-01T00:00:00Z", "DetectedBeacons": [],
            "IsInTarget": False, "WeightKg": 0.0, "UltrasonicDistance": 120.0}


class TestFleetLink:
    def test_a_request_turns_line_following_on_toward_the_customer_room(
        self, tmp_path: Path
    ) -> None:
        """Customer 1 asks: the next exchange (with the robot's own token) says follow the
        line, target room 101."""

        async def main() -> list[Directive]:
            loop = asyncio.get_running_loop()
            app = create_app(f"sqlite:///{tmp_path / 'f.db'}", site=parse_site(SITE),
                             clock=loop_clock(datetime(2026, 1, 1, tzinfo=UTC), loop.time),
                             monitors=False, inline_sqlite=True)
            await app.state.fleet.start()
            seen: list[Directive] = []
            async with httpx.AsyncClient(transport=httpx.ASGITransport(app=app),
                                         base_url="http://fleet") as client:
                link = FleetLink(client, "r1", _report, seen.append,
                                 token="robot-r1-token-0123456789abcdef")
                await link.exchange_once()
                created = await client.post(
                    "/api/requests", json={"CustomerId": 1},
                    headers={"Authorization": "Bearer customer-1-token-0123456789abcdef"})
                assert created.status_code == 201
                await link.exchange_once()
            await app.state.fleet.stop()
            return seen

        before, after = vclock.run(main())
        assert before.line_following is False and before.target_rooms() == []
        assert after.line_following is True and after.target_rooms() == ["101"]

    def test_an_unreachable_server_stops_line_following_after_the_grace_period(self) -> None:
        """Errors are counted and logged; after grace_s the robot is told to stand still."""

        def refuse(_request: httpx.Request) -> httpx.Response:
            raise httpx.ConnectError("connection refused")

        async def main() -> tuple[list[Directive], dict[str, int], float]:
            seen: list[Directive] = []
            loop = asyncio.get_running_loop()
            async with httpx.AsyncClient(transport=httpx.MockTransport(refuse),
                                         base_url="http://fleet") as client:
                link = FleetLink(client, "r1", _report, seen.append, period_s=1.0, grace_s=5.0)
                task = asyncio.create_task(link.run())
                await asyncio.sleep(12)
                task.cancel()
            return seen, link.counts, loop.time()

        seen, counts, _ = vclock.run(main())
        assert seen == [Directive.stand_still()]  # once, not every period
        assert counts["failed"] >= 10 and counts["grace_stops"] == 1

    def test_a_body_of_the_wrong_shape_is_refused_and_nothing_is_applied(self) -> None:
        def nonsense(_request: httpx.Request) -> httpx.Response:
            return httpx.Response(200, json={"IsLineFollowing": "maybe"})

        async def main() -> tuple[list[Directive], FleetLink]:
            seen: list[Directive] = []
            async with httpx.AsyncClient(transport=httpx.MockTransport(nonsense),
                                         base_url="http://fleet") as client:
                link = FleetLink(client, "r1", _report, seen.append)
                assert await link.exchange_once() is None
            return seen, link

        seen, link = vclock.run(main())
        assert seen == []
        assert link.counts["bad_response"] == 1
        assert link.last_error is not None and "IsLineFollowing" in link.last_error

    def test_an_http_error_status_is_reported_with_its_text(self) -> None:
        def unknown(_request: httpx.Request) -> httpx.Response:
            return httpx.Response(404, json={"detail": "robot r1 is not known"})

        async def main() -> FleetLink:
            async with httpx.AsyncClient(transport=httpx.MockTransport(unknown),
                                         base_url="http://fleet") as client:
                link = FleetLink(client, "r1", _report, lambda _d: None)
                await link.exchange_once()
            return link

        link = vclock.run(main())
        assert link.last_error is not None
        assert link.last_error.startswith("HTTP 404") and "not known" in link.last_error
