"""The fleet server inside the simulator: the real fleet app on the simulator's event loop.

Its clock follows virtual time; the robots' real HTTP clients reach it through an ASGI
transport (``sim.actors.asgi_pipe``). Everyone holds a token like on a real site: each robot
its own (in a file its ``fleet.token_file`` names), each customer its own, the staff an admin
token. They are random for each run and seeded through the site (stored hashed, as always).
Used by the laundry site's actors and by the site fleet any scenario may have
(``sim.actors.site_fleet``).
"""

from __future__ import annotations

import asyncio
import secrets
from dataclasses import replace
from datetime import datetime
from pathlib import Path
from typing import Any

import httpx

from fleet.app import create_app
from fleet.clock import loop_clock
from fleet.site import Site
from sim.actors.asgi_pipe import AsgiPipe

FLEET_URL = "http://fleet.sim"


class InProcessFleet:
    """The fleet app on this loop, a SQLite file in the run's work directory. ``client`` is
    the staff's (an admin token of the name ``staff``); ``customer_client(id)`` a
    customer's own."""

    def __init__(self, workdir: Path, site: Site, settings: dict[str, Any],
                 origin: datetime, staff: str = "staff") -> None:
        loop = asyncio.get_running_loop()
        self._tokens: dict[tuple[str, str], str] = {
            ("admin", staff): secrets.token_urlsafe(32),
            **{("robot", str(r["name"])): secrets.token_urlsafe(32) for r in site.robots},
            **{("customer", str(c["id"])): secrets.token_urlsafe(32)
               for c in site.customers if "id" in c},
        }
        site = replace(site, tokens=[*site.tokens, *(
            {"role": role, "subject": subject, "token": token}
            for (role, subject), token in self._tokens.items())])
        self._token_dir = workdir / "fleet-tokens"
        self.app = create_app(f"sqlite:///{workdir / 'fleet.db'}", site=site,
                              clock=loop_clock(origin, loop.time), settings=settings,
                              inline_sqlite=True)
        self.transport = AsgiPipe(self.app)
        self.client = self._client(self._tokens[("admin", staff)])
        self._clients = [self.client]

    def _client(self, token: str | None) -> httpx.AsyncClient:
        headers = {"Authorization": f"Bearer {token}"} if token else None
        return httpx.AsyncClient(transport=self.transport, base_url=FLEET_URL, headers=headers)

    def customer_client(self, customer_id: int) -> httpx.AsyncClient:
        """A client with this customer's own token (none if the site has no such customer)."""
        client = self._client(self._tokens.get(("customer", str(customer_id))))
        self._clients.append(client)
        return client

    def robot_token_file(self, robot: str) -> Path | None:
        """A file (mode 0600) holding this robot's token, for its ``fleet.token_file``; None
        for a robot the site does not have."""
        token = self._tokens.get(("robot", robot))
        if token is None:
            return None
        self._token_dir.mkdir(mode=0o700, exist_ok=True)
        path = self._token_dir / robot
        path.touch(mode=0o600)
        path.write_text(token + "\n", encoding="ascii")
        return path

    async def start(self) -> None:
        await self.app.state.fleet.start()

    async def close(self) -> None:
        for client in self._clients:
            await client.aclose()
        await self.app.state.fleet.stop()
