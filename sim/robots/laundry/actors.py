"""The laundry fleet server inside the simulator, and the people who use it.

``InProcessFleet`` (``sim.actors.fleet_server``) runs the real fleet app on the simulator's
event loop (its clock follows virtual time); the robots' real HTTP clients reach it through an
ASGI transport (``sim.actors.asgi_pipe``). Customers and the laundry staff are actors that use
the same HTTP API a phone app or an admin page would: they create requests, load and unload
the robots' bins, confirm, cancel, mark washing done and pay, each as their scenario table
says.

Everyone holds a token like on a real site: each robot of the site its own (in a file its
``fleet.token_file`` names), each customer its own, the laundry staff an admin token. They
are random for each run and seeded through the site (stored hashed, as always).
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import httpx
import structlog

from robotd.config.settings import Settings
from sim.actors import ActorContext, ActorTask
from sim.actors.fleet_server import FLEET_URL, InProcessFleet
from sim.rig import SimRig
from sim.robots.laundry.hands import OutsideFleetActors
from sim.scenario import read_beside

log = structlog.get_logger(__name__)

__all__ = ["FLEET_URL", "InProcessFleet", "LaundryActors", "send_poll"]

ACTIVE = {"Pending", "Accepted", "ArrivedAtRoom", "LaundryLoaded",
          "FinishedWashingGoingToRoom", "FinishedWashingArrivedAtRoom",
          "FinishedWashingGoingToBase"}
Record = Callable[[dict[str, Any]], None]
SetPayload = Callable[[str, float], None]


@dataclass
class CustomerPlan:
    """What one customer does (a ``[[fleet.customers]]`` table of the scenario)."""

    customer: int
    request_at_s: float
    load_kg: float = 0.0  # 0: never loads (the request times out)
    load_after_s: float = 5.0
    reduce_to_kg: float | None = None  # after an overweight refusal, takes some out
    unload_after_s: float = 5.0
    cancel_in: str | None = None  # cancels as soon as the request has this status
    pays: bool = True

    @classmethod
    def from_table(cls, t: dict[str, Any], where: str) -> CustomerPlan:
        known = set(cls.__dataclass_fields__)
        unknown = set(t) - known
        if unknown:
            msg = f"{where}.{sorted(unknown)[0]}: unknown key (known: {', '.join(sorted(known))})"
            raise ValueError(msg)
        return cls(**t)


async def send_poll(transport: httpx.AsyncBaseTransport, request: httpx.Request
                    ) -> httpx.Response:
    """A poll built once by its client (``build_request``: URL, headers, token) sent straight
    to the transport and read whole. The client's ``send`` adds only its auth flow, redirects,
    hooks, timers and cookies, which no poll of the fleet uses (no redirects, no cookies),
    and they were ~100 of the ~350 us of each once-a-second poll."""
    response = await transport.handle_async_request(request)
    await response.aread()
    return response


class Customer:
    def __init__(self, plan: CustomerPlan, client: httpx.AsyncClient, record: Record,
                 set_payload: SetPayload, transport: httpx.AsyncBaseTransport) -> None:
        self.plan = plan
        self.client = client
        self.transport = transport
        self.record = record
        self.set_payload = set_payload
        self.request_id: int | None = None
        self.status: str | None = None
        self.paid = False
        self._poll: httpx.Request | None = None

    async def run(self) -> None:
        loop = asyncio.get_running_loop()
        await asyncio.sleep(max(0.0, self.plan.request_at_s - loop.time()))
        response = await self.client.post("/api/requests", json={"CustomerId": self.plan.customer})
        self._note("customer.request", response)
        if response.status_code != 201:
            return
        self.request_id = int(response.json()["Id"])
        done: set[str] = set()
        while True:
            request = await self._get()
            status = str(request["Status"])
            if status != self.status:
                self.status = status
                self.record({"kind": "request", "customer": self.plan.customer,
                             "request": self.request_id, "status": status,
                             "robot": request.get("AssignedRobotName")})
            robot = request.get("AssignedRobotName")
            if self.plan.cancel_in == status and "cancel" not in done:
                done.add("cancel")
                await self._act("cancel")
            elif status == "ArrivedAtRoom" and "load" not in done and self.plan.load_kg > 0:
                done.add("load")
                await asyncio.sleep(self.plan.load_after_s)
                await self._load(str(robot))
            elif status == "FinishedWashingArrivedAtRoom" and "unload" not in done:
                done.add("unload")
                await asyncio.sleep(self.plan.unload_after_s)
                self.set_payload(str(robot), 0.0)
                await self._confirm("confirm-unloaded")
            elif status == "Completed" and self.plan.pays and not self.paid:
                self.paid = (await self._act("pay")).status_code == 200
            if status in ("Completed", "Cancelled", "Declined") and (
                    self.paid or not self.plan.pays or status != "Completed"):
                return
            await asyncio.sleep(1.0)

    async def _load(self, robot: str) -> None:
        self.set_payload(robot, self.plan.load_kg)
        await asyncio.sleep(3.0)  # the robot reports a settled weight within its period
        if (await self._confirm("confirm-loaded")).status_code == 409 \
                and self.plan.reduce_to_kg is not None:
            self.set_payload(robot, self.plan.reduce_to_kg)
            await asyncio.sleep(3.0)
            await self._confirm("confirm-loaded")

    async def _confirm(self, action: str) -> httpx.Response:
        """Confirm, retrying while the robot's weight report catches up (409)."""
        response = await self._act(action)
        for _ in range(5):
            if response.status_code != 409 or "Overweight" in response.text \
                    or "overweight" in response.text:
                break
            await asyncio.sleep(2.0)
            response = await self._act(action)
        return response

    async def _act(self, action: str) -> httpx.Response:
        response = await self.client.post(f"/api/requests/{self.request_id}/{action}")
        self._note(f"customer.{action}", response)
        return response

    async def _get(self) -> dict[str, Any]:
        if self._poll is None:  # the same request every second: built once, like an app would
            self._poll = self.client.build_request("GET", f"/api/requests/{self.request_id}")
        response = await send_poll(self.transport, self._poll)
        body: dict[str, Any] = response.json()
        return body

    def _note(self, kind: str, response: httpx.Response) -> None:
        entry: dict[str, Any] = {"kind": kind, "customer": self.plan.customer,
                                 "code": response.status_code}
        if response.status_code >= 400:
            entry["detail"] = response.json().get("detail", response.text[:200])
        self.record(entry)


class Staff:
    """The laundry room: takes the laundry off a robot that stands at base with a load, washes
    it, marks washing done after a while and puts the clean laundry on the robot that delivers.

    They see what a person in the laundry room sees: a robot in the base room with something in
    its bin (``ActorContext.robot_room``, ``payload_kg``), not only what the server says. Once
    in a while they are slow (``slow_unloads``: the n-th unload, counted from 1, waits
    ``slow_unload_s`` instead of ``unload_after_s``)."""

    def __init__(self, client: httpx.AsyncClient, record: Record, set_payload: SetPayload,
                 washing_s: float, transport: httpx.AsyncBaseTransport, *,
                 robot_room: Callable[[str], str | None] = lambda _r: None,
                 payload_kg: Callable[[str], float] = lambda _r: 0.0,
                 robots: tuple[str, ...] = (), base_room: str = "base",
                 unload_after_s: float = 5.0, slow_unloads: tuple[int, ...] = (),
                 slow_unload_s: float = 0.0, fetch_laundry_s: float = 20.0) -> None:
        self.client = client
        self.transport = transport
        self.record = record
        self.set_payload = set_payload
        self.washing_s = washing_s
        self.robot_room = robot_room
        self.payload_kg = payload_kg
        self.robots = robots
        self.base_room = base_room
        self.unload_after_s = unload_after_s
        self.slow_unloads = slow_unloads
        self.slow_unload_s = slow_unload_s
        self.unloads = 0
        self._washing_since: dict[int, float] = {}
        self._clean: dict[int, float] = {}
        """Washed requests (kg of clean laundry) not yet put on the robot that delivers."""
        self._seen_at_base: dict[str, float] = {}
        self._alerts_seen: dict[int, float] = {}
        self._at_base: dict[str, bool] = {}
        self._shared: frozenset[str] = frozenset()
        self.fetch_laundry_s = fetch_laundry_s
        self.double_assignments: list[str] = []
        # The list is asked for every second: the request is built once, like a page would.
        self._poll = client.build_request("GET", "/api/requests")

    async def run(self) -> None:
        loop = asyncio.get_running_loop()
        while True:
            requests = (await send_poll(self.transport, self._poll)).json()
            self._audit(requests, loop.time())
            self._watch_the_line(requests)
            await self._unload_robots_at_base(requests, loop.time())
            await self._answer_alerts(loop.time())
            for r in requests:
                rid = int(r["Id"])
                if r["Status"] == "Washing" and rid not in self._washing_since:
                    robot = str(r["AssignedRobotName"])
                    if self.robots and robot in self.robots and self.payload_kg(robot) > 0:
                        continue  # not in the laundry room yet: nothing to wash
                    self._washing_since[rid] = loop.time()
                    if not self.robots:  # a site whose robots the staff cannot see
                        self.set_payload(robot, 0.0)
                        self.record({"kind": "staff.unloaded", "request": rid, "robot": robot})
                elif r["Status"] == "Washing" and rid not in self._clean and \
                        loop.time() - self._washing_since[rid] >= self.washing_s:
                    response = await self.client.post(f"/api/requests/{rid}/washing-done")
                    if response.status_code == 200:
                        self._clean[rid] = float(r.get("WeightKg") or 4.0)
                        self.record({"kind": "staff.washing_done", "request": rid,
                                     "queued": response.json()["DeliveryQueued"]})
                        self._load_clean(response.json())
                        continue
                self._load_clean(r)
            await asyncio.sleep(1.0)

    def _load_clean(self, request: dict[str, Any]) -> None:
        """Put the washed laundry on the robot that leaves with it (the request has left
        Washing: it is being delivered, or was cancelled meanwhile)."""
        rid = int(request["Id"])
        if rid in self._clean and request["Status"] != "Washing":
            kg = self._clean.pop(rid)
            if request["Status"] == "FinishedWashingGoingToRoom":
                robot = str(request["AssignedRobotName"])
                self.set_payload(robot, kg)
                self.record({"kind": "staff.loaded_clean", "request": rid, "robot": robot})

    def _watch_the_line(self, requests: list[dict[str, Any]]) -> None:
        """What the site's rules are judged by (sim/robots/laundry/checks.py): each robot that
        leaves the base room, with what its bin holds and whether it takes clean laundry out
        (``site.left_base``), and each time more than one robot is out on the line at once
        (``site.line_shared``)."""
        delivering = {str(r["AssignedRobotName"]) for r in requests
                      if r["Status"] == "FinishedWashingGoingToRoom"}
        out = []
        for robot in self.robots:
            at_base = self.robot_room(robot) == self.base_room
            if self._at_base.get(robot, True) and not at_base:
                self.record({"kind": "site.left_base", "robot": robot,
                             "payload_kg": round(self.payload_kg(robot), 3),
                             "delivering": robot in delivering})
            self._at_base[robot] = at_base
            if not at_base:
                out.append(robot)
        shared = frozenset(out) if len(out) > 1 else frozenset()
        if shared and shared != self._shared:
            self.record({"kind": "site.line_shared", "robots": sorted(shared)})
        self._shared = shared

    async def _answer_alerts(self, now: float) -> None:
        """Open alerts are acknowledged when seen; for a robot gone offline with laundry the
        staff walk to it, take the laundry back to the laundry room (``fetch_laundry_s``
        later) and resolve the alert with where the laundry is now: at base."""
        response = await self.client.get("/api/alerts", params={"open": "true"})
        if response.status_code != 200:
            return
        for alert in response.json():
            aid = int(alert["Id"])
            if aid not in self._alerts_seen:
                self._alerts_seen[aid] = now
                ack = await self.client.post(f"/api/alerts/{aid}/acknowledge")
                self.record({"kind": "staff.alert_acknowledged", "alert": aid,
                             "alert_kind": alert["Kind"], "robot": alert.get("RobotName"),
                             "code": ack.status_code})
            if alert.get("IsLaundry") and alert["Kind"] == "robot.offline.laundry" \
                    and now - self._alerts_seen[aid] >= self.fetch_laundry_s:
                robot = str(alert.get("RobotName"))
                self.set_payload(robot, 0.0)
                done = await self.client.post(f"/api/alerts/{aid}/resolve",
                                              json={"LaundryAt": "base"})
                self.record({"kind": "staff.alert_resolved", "alert": aid, "robot": robot,
                             "laundry_at": "base", "code": done.status_code})

    async def _unload_robots_at_base(self, requests: list[dict[str, Any]], now: float) -> None:
        """A robot at base with a load is emptied ``unload_after_s`` after it came (unless it
        is the one taking clean laundry out), and the server is told."""
        delivering = {str(r["AssignedRobotName"]) for r in requests
                      if r["Status"] == "FinishedWashingGoingToRoom"}
        for robot in self.robots:
            loaded = self.payload_kg(robot) > 0 and robot not in delivering
            if self.robot_room(robot) != self.base_room or not loaded:
                self._seen_at_base.pop(robot, None)
                continue
            since = self._seen_at_base.setdefault(robot, now)
            slow = (self.unloads + 1) in self.slow_unloads
            if now - since < (self.slow_unload_s if slow else self.unload_after_s):
                continue
            self.unloads += 1
            self._seen_at_base.pop(robot, None)
            self.set_payload(robot, 0.0)
            response = await self.client.post(f"/api/robots/{robot}/unloaded")
            self.record({"kind": "staff.unloaded", "robot": robot, "slow": slow,
                         "waited_s": round(now - since, 1), "code": response.status_code})

    def _audit(self, requests: list[dict[str, Any]], t_s: float) -> None:
        """No robot may serve two active requests at once."""
        serving: dict[str, list[int]] = {}
        for r in requests:
            if r["Status"] in ACTIVE - {"Pending"} and r["AssignedRobotName"]:
                serving.setdefault(str(r["AssignedRobotName"]), []).append(int(r["Id"]))
        for robot, ids in serving.items():
            if len(ids) > 1:
                problem = f"t={t_s:.1f} s: robot {robot} serves requests {ids}"
                if problem not in self.double_assignments:
                    self.double_assignments.append(problem)
                    self.record({"kind": "double_assignment", "robot": robot, "requests": ids})


class LaundryActors:
    """The laundry site around the robots: the fleet server, its customers and its staff,
    from the scenario's ``[fleet]`` table (none without one)."""

    def __init__(self, ctx: ActorContext, table: dict[str, Any]) -> None:
        from fleet.site import parse_site

        self.scenario = ctx.scenario
        site = parse_site(read_beside(ctx.scenario, str(table.get("site", ""))),
                          str(table.get("site")))
        self.fleet = InProcessFleet(ctx.workdir, site, dict(table.get("settings", {})),
                                    ctx.origin, staff="laundry-staff")
        plans = [CustomerPlan.from_table(t, f"fleet.customers[{i}]")
                 for i, t in enumerate(table.get("customers", []))]
        self.customers = [Customer(p, self.fleet.customer_client(p.customer), ctx.record,
                                   ctx.set_payload, self.fleet.transport) for p in plans]
        self.staff = Staff(self.fleet.client, ctx.record, ctx.set_payload,
                           float(table.get("washing_s", 30.0)), self.fleet.transport,
                           robot_room=ctx.robot_room, payload_kg=ctx.payload_kg,
                           robots=tuple(r.name for r in ctx.scenario.robots),
                           base_room=str(table.get("base_room", "base")),
                           unload_after_s=float(table.get("unload_after_s", 5.0)),
                           slow_unloads=tuple(int(n) for n in table.get("slow_unloads", ())),
                           slow_unload_s=float(table.get("slow_unload_s", 0.0)),
                           fetch_laundry_s=float(table.get("fetch_laundry_s", 20.0)))

    @classmethod
    def for_scenario(cls, ctx: ActorContext) -> LaundryActors | OutsideFleetActors | None:
        """The scenario's own server and people, or (``--fleet-url``) only the people's
        hands around robots that report to an outside server."""
        table = ctx.scenario.raw.get("fleet")
        if ctx.fleet_url:
            return OutsideFleetActors(ctx, table if isinstance(table, dict) else {})
        return cls(ctx, table) if isinstance(table, dict) else None

    async def start(self) -> None:
        await self.fleet.start()

    def configure_robot(self, settings: Settings) -> None:
        settings.set("fleet.url", FLEET_URL)
        token_file = self.fleet.robot_token_file(settings.get("robot.name"))
        if token_file is not None:  # each robot its own token, as on a real site
            settings.set("fleet.token_file", str(token_file))

    def attach(self, rig: SimRig) -> None:
        rig.devices.network = self.fleet.transport

    def people(self) -> list[ActorTask]:
        return [(f"customer.{c.plan.customer}", c.run()) for c in self.customers]

    def background(self) -> list[ActorTask]:
        return [("staff", self.staff.run())]

    def failures(self) -> list[str]:
        return [*self.staff.double_assignments, *self.request_failures()]

    def request_failures(self) -> list[str]:
        """``requests = [{ customer, status, paid? }]``: how each customer's request ended."""
        reasons = []
        by_id = {c.plan.customer: c for c in self.customers}
        for want in self.scenario.success.extra.get("requests", []):
            cid = int(want["customer"])
            c = by_id.get(cid)
            if c is None:
                reasons.append(f"requests: no customer {cid} in [[fleet.customers]]")
                continue
            if c.status != want.get("status"):
                reasons.append(f"customer {cid}'s request ended {c.status}, expected "
                               f"{want.get('status')}")
            if "paid" in want and bool(want["paid"]) != c.paid:
                reasons.append(f"customer {cid} {'did not pay' if want['paid'] else 'paid'}")
        return reasons

    async def close(self) -> None:
        await self.fleet.close()
