"""A test harness around the fleet app: a settable clock, a small site with its tokens, HTTP
helpers that call as a real site's clients do (robots with their own tokens, the rest as
admin unless a test says otherwise)."""

from __future__ import annotations

import re
from collections.abc import Generator
from datetime import UTC, datetime, timedelta
from typing import Any

import httpx

from fleet.app import create_app
from fleet.server import FleetServer
from fleet.site import parse_site

BASE_MAC = "C3:00:00:00:00:01"
ROOM_MACS = {1: "C3:00:00:00:01:01", 2: "C3:00:00:00:01:02", 3: "C3:00:00:00:02:01",
             4: "C3:00:00:00:02:02"}

SITE_TOML = f"""
[[rooms]]
name = "Laundry"
floor_color = "blue"

[[rooms]]
name = "Room 101"
floor_color = "red"

[[rooms]]
name = "Room 102"

[[rooms]]
name = "Room 201"

[[rooms]]
name = "Room 202"

[[rooms]]
name = "Lobby"

[[beacons]]
mac = "{BASE_MAC}"
name = "base-1"
room = "Laundry"
rssi_threshold_dbm = -65
base = true

[[beacons]]
mac = "{ROOM_MACS[1]}"
name = "room-101"
room = "Room 101"

[[beacons]]
mac = "{ROOM_MACS[2]}"
name = "room-102"
room = "Room 102"

[[beacons]]
mac = "{ROOM_MACS[3]}"
name = "room-201"
room = "Room 201"

[[beacons]]
mac = "{ROOM_MACS[4]}"
name = "room-202"
room = "Room 202"

[[customers]]
id = 1
name = "Alice"
beacon = "{ROOM_MACS[1]}"

[[customers]]
id = 2
name = "Bob"
beacon = "{ROOM_MACS[2]}"

[[customers]]
id = 3
name = "Carol"
beacon = "{ROOM_MACS[3]}"

[[customers]]
id = 4
name = "Dave"
beacon = "{ROOM_MACS[4]}"

[[customers]]
id = 5
name = "Eve (no beacon)"
room = "Lobby"

[[robots]]
name = "robot-1"

[[robots]]
name = "robot-2"
"""


def token_for(role: str, subject: str) -> str:
    """The test site's token of this caller (seeded through the site file, stored hashed)."""
    return f"test-{role}-{subject}-token-0123456789abcdef"


TOKENS = [("admin", "staff"), ("robot", "robot-1"), ("robot", "robot-2"),
          *(("customer", str(c)) for c in range(1, 6))]
SITE_TOML += "".join(f"""
[[tokens]]
role = "{role}"
subject = "{subject}"
token = "{token_for(role, subject)}"
""" for role, subject in TOKENS)

_ROBOT_PATH = re.compile(r"^/api/Robot/([^/]+)/")


def bearer(token: str) -> dict[str, str]:
    return {"Authorization": f"Bearer {token}"}


class SiteAuth(httpx.Auth):
    """Robots' data exchanges with the robot's own token; everything else as admin. A request
    that already has an Authorization header keeps it."""

    def auth_flow(self, request: httpx.Request) -> Generator[httpx.Request, httpx.Response, None]:
        if "authorization" not in request.headers:
            match = _ROBOT_PATH.match(request.url.path)
            token = (token_for("robot", match.group(1)) if match
                     else token_for("admin", "staff"))
            request.headers["Authorization"] = f"Bearer {token}"
        yield request


class FakeClock:
    """A wall clock the test moves by hand."""

    def __init__(self) -> None:
        self.now = datetime(2026, 1, 5, 8, 0, tzinfo=UTC)

    def __call__(self) -> datetime:
        return self.now

    def advance(self, seconds: float) -> None:
        self.now += timedelta(seconds=seconds)


def beacon(mac: str, rssi: int = -50) -> dict[str, Any]:
    return {"MacAddress": mac, "Uuid": "fda50693-a4e2-4fb1-afcf-c6eb07647825", "Major": 1,
            "Minor": 1, "Rssi": rssi, "Distance": 0.5}


class Fleet:
    """The app, its server, a client and helpers named after what customers/robots do."""

    def __init__(self, db_url: str, settings: dict[str, Any] | None = None,
                 site_toml: str = SITE_TOML, auth_failures_per_min: int = 0,
                 *, report: bool = True) -> None:
        self.clock = FakeClock()
        site = parse_site(site_toml, "test-site")
        # Online means reported: the site's robots make their first data exchange at start,
        # as real ones do within a second (``report=False``: they stay unheard of).
        self.reporting = [str(r["name"]) for r in site.robots] if report else []
        self.app = create_app(db_url, site=site, clock=self.clock,
                              settings=settings, auth_failures_per_min=auth_failures_per_min)
        self.server: FleetServer = self.app.state.fleet
        self.http = httpx.AsyncClient(transport=httpx.ASGITransport(app=self.app),
                                      base_url="http://fleet", auth=SiteAuth())

    async def __aenter__(self) -> Fleet:
        await self.server.start(monitors=False)
        for robot in self.reporting:
            await self.exchange(robot)
        return self

    async def report_all(self) -> None:
        """Every reporting robot makes a data exchange now (after the clock moved on, so that
        they still count as online)."""
        for robot in self.reporting:
            await self.exchange(robot)

    async def __aexit__(self, *exc: object) -> None:
        await self.http.aclose()
        await self.server.stop()

    async def create(self, customer_id: int) -> httpx.Response:
        return await self.http.post("/api/requests", json={"CustomerId": customer_id})

    async def request(self, customer_id: int) -> dict[str, Any]:
        response = await self.create(customer_id)
        assert response.status_code == 201, response.text
        body: dict[str, Any] = response.json()
        return body

    async def get(self, request_id: int) -> dict[str, Any]:
        response = await self.http.get(f"/api/requests/{request_id}")
        assert response.status_code == 200, response.text
        body: dict[str, Any] = response.json()
        return body

    async def status(self, request_id: int) -> str:
        return str((await self.get(request_id))["Status"])

    async def act(self, request_id: int, action: str) -> httpx.Response:
        return await self.http.post(f"/api/requests/{request_id}/{action}")

    async def do(self, request_id: int, action: str) -> dict[str, Any]:
        response = await self.act(request_id, action)
        assert response.status_code == 200, response.text
        body: dict[str, Any] = response.json()
        return body

    async def exchange(self, robot: str, *, beacons: list[dict[str, Any]] | None = None,
                       in_target: bool = False, weight_kg: float | None = 0.0,
                       **extra: Any) -> dict[str, Any]:
        response = await self.http.post(f"/api/Robot/{robot}/data-exchange", json={
            "RobotName": robot, "Timestamp": self.clock().isoformat(),
            "DetectedBeacons": beacons or [], "IsInTarget": in_target, "WeightKg": weight_kg,
            "UltrasonicDistance": 80.0, **extra})
        assert response.status_code == 200, response.text
        body: dict[str, Any] = response.json()
        return body

    async def arrive_at_room(self, robot: str, customer_id: int,
                             weight_kg: float | None = 0.0) -> dict[str, Any]:
        return await self.exchange(robot, beacons=[beacon(ROOM_MACS[customer_id])],
                                   in_target=True, weight_kg=weight_kg)

    async def arrive_at_base(self, robot: str, rssi: int = -50,
                             weight_kg: float | None = 0.0) -> dict[str, Any]:
        return await self.exchange(robot, beacons=[beacon(BASE_MAC, rssi)], in_target=True,
                                   weight_kg=weight_kg)

    async def unloaded(self, robot: str) -> dict[str, Any]:
        """The staff take the load off a robot back at base: it may go out again at once
        (otherwise it waits for its load cell to read empty for UnloadSettledS)."""
        response = await self.http.post(f"/api/robots/{robot}/unloaded")
        assert response.status_code == 200, response.text
        body: dict[str, Any] = response.json()
        return body

    async def robots(self) -> dict[str, dict[str, Any]]:
        response = await self.http.get("/api/robots")
        return {r["Name"]: r for r in response.json()}

    async def notifications(self, **params: Any) -> list[dict[str, Any]]:
        response = await self.http.get("/api/notifications", params=params)
        assert response.status_code == 200, response.text
        body: list[dict[str, Any]] = response.json()
        return body

    async def settings(self, **values: Any) -> dict[str, Any]:
        response = await self.http.put("/api/settings", json=values)
        assert response.status_code == 200, response.text
        body: dict[str, Any] = response.json()
        return body


def targets(reply: dict[str, Any]) -> set[str]:
    return {b["Name"] for b in reply["ActiveBeacons"] if b["IsNavigationTarget"]}


# Requests in a given state, robots gone quiet, alerts (issue 27's tests share them).

async def loaded(fleet: Fleet, customer: int = 1, robot: str = "robot-1") -> int:
    """A request whose robot holds the customer's dirty laundry (LaundryLoaded)."""
    request = await fleet.request(customer)
    assert request["AssignedRobotName"] == robot
    await fleet.arrive_at_room(robot, customer, weight_kg=3.0)
    await fleet.do(request["Id"], "confirm-loaded")
    return int(request["Id"])


async def delivering(fleet: Fleet, customer: int = 1) -> int:
    """A request whose robot-1 carries the clean laundry back (FinishedWashingGoingToRoom)."""
    request_id = await loaded(fleet, customer)
    await fleet.arrive_at_base("robot-1", weight_kg=3.0)
    await fleet.unloaded("robot-1")
    await fleet.do(request_id, "washing-done")
    assert (await fleet.get(request_id))["AssignedRobotName"] == "robot-1"
    return request_id


async def offline(fleet: Fleet, robot: str = "robot-1") -> None:
    """``robot`` falls silent; the other one keeps reporting."""
    fleet.clock.advance(31)
    for other in ("robot-1", "robot-2"):
        if other != robot:
            await fleet.exchange(other)
    assert await fleet.server.check_offline() == [robot]


async def alerts(fleet: Fleet, **params: Any) -> list[dict[str, Any]]:
    response = await fleet.http.get("/api/alerts", params=params)
    assert response.status_code == 200, response.text
    body: list[dict[str, Any]] = response.json()
    return body


async def resolve(fleet: Fleet, alert_id: int, laundry_at: str | None = None) -> Any:
    body = {"LaundryAt": laundry_at} if laundry_at is not None else None
    return await fleet.http.post(f"/api/alerts/{alert_id}/resolve", json=body)
