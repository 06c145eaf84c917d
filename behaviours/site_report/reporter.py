"""The site status loop: every ``fleet.period_s`` one POST of the robot's status to its fleet
server, and the staff's orders in the answer applied.

The server being away never stops or slows the robot: a failed report is logged once (until
it changes or the server answers again) and the next period tries again; the orders last
received stay as they are (an e-stop stays until the server lifts it).
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from typing import Any

import httpx
import structlog

from behaviours.site_report.orders import StaffOrders

log = structlog.get_logger(__name__)


class BadAnswer(ValueError):
    """The server's answer is not the status reply (docs/fleet.md "Site status")."""


def parse_answer(body: Any) -> tuple[bool, bool]:
    """``(EmergencyStop, MaintenanceMode)`` of the answer; BadAnswer otherwise."""
    if not isinstance(body, dict):
        msg = f"expected a JSON object, got {type(body).__name__}"
        raise BadAnswer(msg)
    flags = []
    for key in ("EmergencyStop", "MaintenanceMode"):
        value = body.get(key)
        if not isinstance(value, bool):
            msg = f"{key}: expected true or false, got {value!r}"
            raise BadAnswer(msg)
        flags.append(value)
    return flags[0], flags[1]


class SiteReporter:
    """Reports the robot's status to ``POST /api/Robot/{robot_name}/status``.

    Args:
        client: an ``httpx.AsyncClient`` whose base URL is ``fleet.url``.
        robot_name: ``robot.name``.
        build: the body for this period (``status.status_body``).
        orders: applies the answer's e-stop and maintenance.
        period_s: read before each wait (``fleet.period_s`` is tunable).
        timeout_s: the per-request timeout.
        token: the robot's bearer token (``fleet.token_file``); None sends none.
    """

    name = "site_report"
    critical = False
    depends_on: tuple[str, ...] = ()

    def __init__(self, client: httpx.AsyncClient, robot_name: str,
                 build: Callable[[], dict[str, Any]], orders: StaffOrders, *,
                 period_s: Callable[[], float], timeout_s: float = 2.0,
                 token: str | None = None) -> None:
        self.client = client
        self.robot_name = robot_name
        self.build = build
        self.orders = orders
        self.period_s = period_s
        self.timeout_s = timeout_s
        self.headers = {"Authorization": f"Bearer {token}"} if token else {}
        self.counts = dict.fromkeys(("sent", "ok", "failed"), 0)
        self.last_error: str | None = None

    @property
    def path(self) -> str:
        return f"/api/Robot/{self.robot_name}/status"

    async def run(self, ready: Callable[[], None]) -> None:
        ready()
        loop = asyncio.get_running_loop()
        next_at = loop.time()
        while True:
            await self.report_once()
            next_at = max(next_at + self.period_s(), loop.time())
            await asyncio.sleep(next_at - loop.time())

    async def report_once(self) -> bool:
        """One report; True when the server answered and its orders were applied."""
        self.counts["sent"] += 1
        try:
            body = self.build()
            response = await self.client.post(self.path, json=body, headers=self.headers,
                                              timeout=self.timeout_s)
        except httpx.HTTPError as exc:
            return self._failed(f"{type(exc).__name__}: {exc}" if str(exc)
                                else type(exc).__name__)
        if response.status_code != 200:
            return self._failed(f"HTTP {response.status_code}: {response.text[:200]}")
        try:
            estop, maintenance = parse_answer(response.json())
        except ValueError as exc:  # BadAnswer, or not JSON at all
            return self._failed(f"bad answer: {exc}")
        self.counts["ok"] += 1
        if self.last_error is not None:
            log.info("site.reachable", after_error=self.last_error)
            self.last_error = None
        await self.orders.apply(estop, maintenance)
        return True

    def _failed(self, error: str) -> bool:
        self.counts["failed"] += 1
        if error != self.last_error:
            log.warning("site.report_failed", error=error,
                        url=f"{self.client.base_url}{self.path}")
        self.last_error = error
        return False

    def status(self) -> dict[str, Any]:
        """For ``robotctl status``: reports sent, answered, failed, the last error."""
        return {**self.counts, "last_error": self.last_error, "period_s": self.period_s()}
