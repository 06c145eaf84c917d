"""The fleet traffic of a ``robotd sim laundry`` run, timed in process: the robot's data
exchange (its real ``FleetLink``), a customer's and the staff's polls, the ping flush and the
monitors' passes, through the simulator's transport (``AsgiPipe``) to the app on inline SQLite,
on the simulator's virtual-time loop with 1 s between calls (so the caches' snapshots expire as
in a run). Prints CPU microseconds per call.

    .venv/bin/python bench/bench_fleet_sim.py [CALLS]     (or bench_fleet.py --simulator CALLS)
"""

from __future__ import annotations

import asyncio
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))


def simulator_calls(calls: int) -> None:
    """Per-call CPU of the laundry run's fleet traffic, in process (``--simulator``)."""
    from datetime import UTC, datetime

    from behaviours.profiles.laundry.fleet_link import FleetLink, fleet_client, read_token
    from fleet.site import parse_site
    from sim import vclock
    from sim.robots.laundry.actors import InProcessFleet, send_poll

    site_file = ROOT / "sim" / "robots" / "laundry" / "scenarios" / "laundry-site.toml"
    report = {"RobotName": "laundry-1", "Timestamp": "2026-01-05T08:00:00Z",
              "DetectedBeacons": [{"MacAddress": "C0:FF:EE:00:00:01", "Major": 1, "Minor": 1,
                                   "Uuid": "E2C56DB5-DFFB-48D2-B060-D0F5A71096E0",
                                   "Rssi": -60, "Distance": 1.2}],
              "IsInTarget": False, "WeightKg": 0.0, "UltrasonicDistance": 120.5}

    async def timed(label: str, call: Any, gap_s: float = 1.0) -> None:
        for _ in range(20):
            await call()
            await asyncio.sleep(gap_s)
        spent = 0.0
        for _ in range(calls):
            start = time.process_time()
            await call()
            spent += time.process_time() - start
            await asyncio.sleep(gap_s)
        print(f"{label:40s} {1e6 * spent / calls:7.1f} us", flush=True)

    async def run() -> None:
        with tempfile.TemporaryDirectory(prefix="bench-fleet-sim-") as workdir:
            fleet = InProcessFleet(Path(workdir), parse_site(site_file.read_text(), "site"),
                                   {"AutoAccept": True, "ArrivedTimeoutS": 86400.0},
                                   datetime(2026, 1, 5, 8, 0, tzinfo=UTC))
            await fleet.app.state.fleet.start(monitors=False)
            server = fleet.app.state.fleet
            token_file = fleet.robot_token_file("laundry-1")
            assert token_file is not None
            robot = fleet_client("http://fleet.sim", transport=fleet.transport)
            link = FleetLink(robot, "laundry-1", lambda: dict(report), lambda _d: None,
                             token=read_token(token_file))
            customer = fleet.customer_client(2)
            created = await customer.post("/api/requests", json={"CustomerId": 2})
            one = customer.build_request("GET", f"/api/requests/{created.json()['Id']}")
            listed = fleet.client.build_request("GET", "/api/requests")

            async def ping_and_flush() -> None:
                await link.exchange_once()
                await server.flush_pings()

            await timed("robot exchange (snapshots fresh)", link.exchange_once, 0.0)
            await timed("robot exchange (1 s apart)", link.exchange_once)
            await timed("customer GET /api/requests/{id}", lambda: send_poll(fleet.transport,
                                                                              one))
            await timed("staff GET /api/requests", lambda: send_poll(fleet.transport, listed))
            await timed("exchange + flush_pings", ping_and_flush)
            await timed("timeout monitor pass (nothing due)", server.check_timeouts)
            await timed("offline monitor pass", server.check_offline)
            await robot.aclose()
            await fleet.close()

    vclock.run(run())


if __name__ == "__main__":
    simulator_calls(int(sys.argv[1]) if len(sys.argv) > 1 else 1000)
