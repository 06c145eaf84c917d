"""A fleet server for any scenario's robots (issue 29): the scenario's ``[fleet]`` table gives
the robots whose simulator slice runs no fleet of its own (``SimSlice.runs_fleet``) the real
fleet server, in process; each reports its site status to it (``behaviours.site_report``).

```toml
[fleet]
site = "site.toml"          # optional: rooms, robots, settings (the scenario's robots are added)
settings = { OfflineAfterS = 10 }
watch_s = 2.0               # how often the staff look at the robot list and the alerts
orders = [                  # the staff's orders from the server, at scenario times
    { at_s = 30.0, robot = "vac-1", order = "estop" },
    { at_s = 40.0, robot = "vac-1", order = "resume" },
]
```

With ``robotd sim --fleet-url URL --fleet-token-file FILE`` the robots report to that outside
server instead (``OutsideSiteFleet``): its staff are real people at its console, so the
table's ``orders`` are not played and nothing of the server is recorded (FILE may name each
robot as ``{robot}``).

What the staff see goes into the run's events: ``fleet.robot`` each time a robot's state,
fault or e-stop in the robot list changes (with its pose and job), ``fleet.alert`` for each
new alert, ``fleet.order`` for each order given (with the HTTP status).
"""

from __future__ import annotations

import asyncio
from dataclasses import replace
from typing import Any, Final

import structlog

from robotd.config.settings import Settings
from sim.actors import ActorContext, ActorTask
from sim.actors.fleet_server import FLEET_URL, InProcessFleet
from sim.rig import SimRig
from sim.scenario import SITE_FLEET_KEYS, read_beside

log = structlog.get_logger(__name__)

KEYS: Final = SITE_FLEET_KEYS
"""The ``[fleet]`` keys this reads (a laundry slice's actors read theirs)."""
ORDERS: Final = {"estop": ("estop", None), "resume": ("resume", None),
                 "maintenance": ("maintenance", {"On": True}),
                 "maintenance_end": ("maintenance", {"On": False})}
"""An order's name -> the admin endpoint under ``/api/robots/{name}/`` and its body."""
_SHOWN: Final = ("State", "Fault", "EmergencyStop", "EmergencyStopActive", "MaintenanceMode")


def _orders(table: dict[str, Any], robots: tuple[str, ...]) -> list[tuple[float, str, str]]:
    out = []
    for i, entry in enumerate(table.get("orders", [])):
        where = f"fleet.orders[{i}]"
        if not isinstance(entry, dict) or set(entry) != {"at_s", "robot", "order"}:
            msg = f"{where}: expected {{ at_s, robot, order }}"
            raise ValueError(msg)
        if entry["order"] not in ORDERS:
            msg = f"{where}.order: {entry['order']!r} is not one of {', '.join(ORDERS)}"
            raise ValueError(msg)
        if entry["robot"] not in robots:
            msg = f"{where}.robot: no robot {entry['robot']!r} in the scenario"
            raise ValueError(msg)
        out.append((float(entry["at_s"]), str(entry["robot"]), str(entry["order"])))
    return sorted(out)


class SiteFleetActors:
    """The site's fleet server and its staff, for the robots named (those of profiles whose
    slice runs no fleet of its own)."""

    def __init__(self, ctx: ActorContext, table: dict[str, Any], robots: tuple[str, ...]) -> None:
        from fleet.site import Site, parse_site

        site = (parse_site(read_beside(ctx.scenario, str(table["site"])), str(table["site"]))
                if "site" in table else Site())
        listed = {str(r["name"]) for r in site.robots}
        site = replace(site, robots=[*site.robots,
                                     *({"name": r} for r in robots if r not in listed)])
        self.robots = robots
        self.fleet = InProcessFleet(ctx.workdir, site, dict(table.get("settings", {})),
                                    ctx.origin)
        self.record = ctx.record
        self.watch_s = float(table.get("watch_s", 2.0))
        if not self.watch_s > 0:
            msg = "fleet.watch_s: expected a period > 0"
            raise ValueError(msg)
        self.orders = _orders(table, robots)
        self._shown: dict[str, tuple[Any, ...]] = {}
        self._alerts: set[int] = set()

    async def start(self) -> None:
        await self.fleet.start()

    def configure_robot(self, settings: Settings) -> None:
        if settings.get("robot.name") not in self.robots:
            return
        settings.set("fleet.url", FLEET_URL)
        token_file = self.fleet.robot_token_file(settings.get("robot.name"))
        if token_file is not None:
            settings.set("fleet.token_file", str(token_file))

    def attach(self, rig: SimRig) -> None:
        if rig.settings.get("robot.name") in self.robots:
            rig.devices.network = self.fleet.transport

    def people(self) -> list[ActorTask]:
        return []

    def background(self) -> list[ActorTask]:
        return [("fleet.staff", self._staff()), ("fleet.watch", self._watch())]

    def failures(self) -> list[str]:
        return []

    async def close(self) -> None:
        await self.fleet.close()

    async def _staff(self) -> None:
        loop = asyncio.get_running_loop()
        start = loop.time()
        for at_s, robot, order in self.orders:
            await asyncio.sleep(max(0.0, start + at_s - loop.time()))
            endpoint, body = ORDERS[order]
            response = await self.fleet.client.post(f"/api/robots/{robot}/{endpoint}",
                                                    json=body)
            self.record({"kind": "fleet.order", "robot": robot, "order": order,
                         "code": response.status_code})

    async def _watch(self) -> None:
        while True:
            await asyncio.sleep(self.watch_s)
            await self.look()

    async def look(self) -> None:
        """The staff look at the robot list and the alerts once (recorded when changed)."""
        robots = await self.fleet.client.get("/api/robots")
        if robots.status_code == 200:
            for robot in robots.json():
                if robot["Name"] not in self.robots:
                    continue
                shown = tuple(str(robot.get(k)) for k in _SHOWN)
                if self._shown.get(robot["Name"]) != shown:
                    self._shown[robot["Name"]] = shown
                    self.record({"kind": "fleet.robot", "robot": robot["Name"],
                                 "profile": robot.get("Profile"), "state": robot.get("State"),
                                 "fault": robot.get("Fault"), "pose": robot.get("Pose"),
                                 "place": robot.get("Place"), "job": robot.get("Job"),
                                 "estop": robot.get("EmergencyStopActive"),
                                 "battery_pct": robot.get("BatteryPct")})
        alerts = await self.fleet.client.get("/api/alerts")
        if alerts.status_code == 200:
            for alert in alerts.json():
                if alert["Id"] not in self._alerts:
                    self._alerts.add(alert["Id"])
                    self.record({"kind": "fleet.alert", "alert": alert["Id"],
                                 "alert_kind": alert["Kind"], "code": alert.get("Code"),
                                 "robot": alert.get("RobotName"), "message": alert["Message"]})


class OutsideSiteFleet:
    """The robots named report to an outside fleet server (``robotd sim --fleet-url``)."""

    def __init__(self, url: str, token_file: str | None, robots: tuple[str, ...]) -> None:
        self.url = url
        self.token_file = token_file
        self.robots = robots

    async def start(self) -> None:
        """Nothing to start: the server runs on its own."""

    def configure_robot(self, settings: Settings) -> None:
        name = settings.get("robot.name")
        if name not in self.robots:
            return
        settings.set("fleet.url", self.url)
        if self.token_file:
            settings.set("fleet.token_file", self.token_file.replace("{robot}", name))

    def attach(self, rig: SimRig) -> None:
        """The robots reach the server through the operating system's network."""

    def people(self) -> list[ActorTask]:
        return []

    def background(self) -> list[ActorTask]:
        return []

    def failures(self) -> list[str]:
        return []

    async def close(self) -> None:
        """Nothing to close."""


def site_fleet_for(ctx: ActorContext, robots: list[tuple[str, bool]]
                   ) -> SiteFleetActors | OutsideSiteFleet | None:
    """The site fleet of the scenario's ``[fleet]`` table for the robots (name, whether its
    slice runs its own fleet) that have none of their own, or the outside server of
    ``--fleet-url``; None without such a table or such robots."""
    table = ctx.scenario.raw.get("fleet")
    mine = tuple(name for name, own in robots if not own)
    if not isinstance(table, dict) or not mine:
        return None
    if ctx.fleet_url:
        return OutsideSiteFleet(ctx.fleet_url, ctx.fleet_token_file, mine)
    return SiteFleetActors(ctx, table, mine)
