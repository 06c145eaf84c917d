"""The 1 s data exchange with the fleet server (seed 000 section 8), robot side.

Every ``fleet.period_s`` the robot POSTs its report and applies the answer. When the server
cannot be reached (or answers nonsense) the robot logs it and keeps trying; after
``laundry.server_grace_s`` without a good answer it stops line following rather than wander.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from typing import Any

import httpx
import structlog

from behaviours.profiles.laundry.directive import BadResponse, Directive, parse_exchange_response
from behaviours.site_report.client import (
    CREDENTIAL,
    FleetClient,
    NoCookies,
    TokenFileError,
    fleet_client,
    read_token,
    token_path,
)

__all__ = ["CREDENTIAL", "FleetClient", "FleetLink", "NoCookies", "TokenFileError",
           "fleet_client", "read_token", "token_path"]

log = structlog.get_logger(__name__)


class FleetLink:
    """Runs the exchange loop; ``on_directive`` gets every good answer (and the grace stop).

    Args:
        client: an ``httpx.AsyncClient`` whose base URL is ``fleet.url`` (the simulator gives
            one on an ASGI transport to the in-process server).
        robot_name: ``robot.name``, the path parameter of the endpoint.
        build_report: returns the request body for this period.
        period_s, grace_s, timeout_s: exchange period, how long without an answer the robot
            goes on with its last directive, and the per-request timeout.
        token: the robot's bearer token (``fleet.token_file``), sent as
            ``Authorization: Bearer``; None sends none.
    """

    def __init__(self, client: httpx.AsyncClient, robot_name: str,
                 build_report: Callable[[], dict[str, Any]],
                 on_directive: Callable[[Directive], None], *, period_s: float = 1.0,
                 grace_s: float = 5.0, timeout_s: float = 2.0,
                 token: str | None = None) -> None:
        self.client = client
        self.robot_name = robot_name
        self.build_report = build_report
        self.on_directive = on_directive
        self.period_s = period_s
        self.grace_s = grace_s
        self.timeout_s = timeout_s
        self.counts = dict.fromkeys(("sent", "ok", "failed", "bad_response", "grace_stops"), 0)
        self.last_error: str | None = None
        self.last_ok_s: float | None = None
        self._grace_stopped = False
        # What client.build_request would merge into every request, merged once: the URL on
        # the base URL, the client's headers and the token, the timeout. The client's headers
        # are read here: a client whose headers change later needs a new link.
        self._auth = {"Authorization": f"Bearer {token}"} if token else None
        self._url = client.build_request("POST", self.path).url
        self._request_headers = httpx.Headers(client.headers)
        self._request_headers.update(self._auth)
        self._timeout = httpx.Timeout(timeout_s).as_dict()

    @property
    def path(self) -> str:
        return f"/api/Robot/{self.robot_name}/data-exchange"

    def request(self, report: dict[str, Any]) -> httpx.Request:
        """The exchange request carrying ``report``: the one ``client.build_request`` builds
        for ``POST path`` with the token and timeout (its cookies too, when the client has
        any), built from what does not change between requests."""
        if self.client.cookies:
            return self.client.build_request("POST", self.path, json=report,
                                             headers=self._auth, timeout=self.timeout_s)
        return httpx.Request("POST", self._url, json=report, headers=self._request_headers,
                             extensions={"timeout": self._timeout})

    async def run(self) -> None:
        loop = asyncio.get_running_loop()
        started = loop.time()
        next_at = started
        while True:
            await self.exchange_once()
            silent_since = self.last_ok_s if self.last_ok_s is not None else started
            if loop.time() - silent_since >= self.grace_s and not self._grace_stopped:
                self._grace_stopped = True
                self.counts["grace_stops"] += 1
                log.warning("fleet.grace_expired", silent_s=round(loop.time() - silent_since, 1),
                            action="stop line following")
                self.on_directive(Directive.stand_still())
            next_at += self.period_s
            await asyncio.sleep(max(0.0, next_at - loop.time()))

    async def exchange_once(self) -> Directive | None:
        """One POST; applies and returns the directive, or None when there was none."""
        self.counts["sent"] += 1
        try:
            response = await self.client.send(self.request(self.build_report()))
        except httpx.HTTPError as exc:
            self._failed(f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__)
            return None
        if response.status_code != 200:
            self._failed(f"HTTP {response.status_code}: {response.text[:200]}")
            return None
        try:
            directive = parse_exchange_response(response.json())
        except (ValueError, BadResponse) as exc:
            self.counts["bad_response"] += 1
            self._failed(f"bad response: {exc}")
            return None
        self.counts["ok"] += 1
        if self.last_error is not None:
            log.info("fleet.reachable", after_error=self.last_error)
        self.last_error = None
        self.last_ok_s = asyncio.get_running_loop().time()
        self._grace_stopped = False
        self.on_directive(directive)
        return directive

    def _failed(self, error: str) -> None:
        self.counts["failed"] += 1
        if error != self.last_error:
            log.warning("fleet.exchange_failed", error=error, url=f"{self.client.base_url}"
                        f"{self.path}")
        self.last_error = error

    def status(self) -> dict[str, Any]:
        return {**self.counts, "last_error": self.last_error, "period_s": self.period_s}
