"""Every robot's site status (issue 29) against the laundry data exchange, in process: N
robots each report once a "second" (the server's clock moved by hand, the ping batch flushed
between rounds as its monitor would), half through ``POST /api/Robot/{name}/status``, half
through the data exchange, on SQLite (and PostgreSQL when a server can be started). Prints
p50/p99 per request of the exchange (the baseline, same run), of a quiet status, of a status
whose fault code changes (a write transaction and an alert), of ``GET /api/robots``, and of
the batch flush.

    .venv/bin/python bench/bench_site_status.py [--robots 200] [--rounds 10] [--backend sqlite]

In-process (httpx's ASGI transport, no sockets): the figures are the server's own cost per
request on this machine, not a network's.
"""

from __future__ import annotations

import argparse
import asyncio
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests" / "support"))
sys.path.insert(0, str(ROOT / "tests" / "fleet"))

from fleet_harness import SITE_TOML, Fleet, bearer, token_for  # noqa: E402
from pgtest import PgCluster, PgUnavailable  # noqa: E402


def site(robots: int) -> str:
    return SITE_TOML + "".join(
        f'\n[[robots]]\nname = "bot-{i}"\n\n[[tokens]]\nrole = "robot"\nsubject = "bot-{i}"\n'
        f'token = "{token_for("robot", f"bot-{i}")}"\n' for i in range(robots))


def status(i: int, round_no: int, fault: bool) -> dict[str, Any]:
    return {"Profile": "delivery", "State": "mission.to_customer",
            "EmergencyStopActive": False, "BatteryPct": 80.0 - round_no / 10,
            "Fault": {"Code": "stuck", "Message": "error recovery: stuck"} if fault else None,
            "Pose": {"X": i * 0.1, "Y": round_no * 0.1, "Theta": 0.5, "Map": "depot"},
            "Job": f"order {i}"}


def pct(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))] * 1000


async def timed(into: list[float], call: Any) -> Any:
    start = time.perf_counter()
    result = await call
    into.append(time.perf_counter() - start)
    return result


async def run(db_url: str, robots: int, rounds: int) -> dict[str, list[float]]:
    fleet = Fleet(db_url, site_toml=site(robots))
    fleet.reporting = []
    out: dict[str, list[float]] = {k: [] for k in (
        "exchange", "status_quiet", "status_fault", "robots", "flush")}
    async with fleet:
        for i in range(robots):  # first reports: every robot known and online
            await fleet.http.post(f"/api/Robot/bot-{i}/status", json=status(i, 0, False),
                                  headers=bearer(token_for("robot", f"bot-{i}")))
        for robot in ("robot-1", "robot-2"):
            await fleet.exchange(robot)
        for round_no in range(1, rounds + 1):
            fleet.clock.advance(1.0)
            for i in range(robots):
                fault = round_no % 5 == 0 and i % 10 == 0  # a fault comes, then clears
                key = "status_fault" if fault or (round_no % 5 == 1 and i % 10 == 0
                                                  and round_no > 1) else "status_quiet"
                response = await timed(out[key], fleet.http.post(
                    f"/api/Robot/bot-{i}/status", json=status(i, round_no, fault),
                    headers=bearer(token_for("robot", f"bot-{i}"))))
                assert response.status_code == 200, response.text
                robot = ("robot-1", "robot-2")[i % 2]
                await timed(out["exchange"], fleet.exchange(robot, State="mission.to_room",
                                                            EmergencyStopActive=False,
                                                            BatteryPct=70.0))
            await timed(out["flush"], fleet.server.flush_pings())
            await timed(out["robots"], fleet.http.get("/api/robots"))
    return out


def report(backend: str, robots: int, figures: dict[str, list[float]]) -> None:
    print(f"{backend}, {robots} status robots:")
    for key, values in figures.items():
        print(f"  {key:13s} n={len(values):5d} p50={pct(values, 0.5):7.2f} ms "
              f"p99={pct(values, 0.99):7.2f} ms")


async def main(args: argparse.Namespace) -> int:
    with tempfile.TemporaryDirectory() as tmp:
        if args.backend in ("sqlite", "both"):
            report("sqlite", args.robots,
                   await run(f"sqlite:///{tmp}/fleet.db", args.robots, args.rounds))
        if args.backend in ("postgres", "both"):
            try:
                cluster = PgCluster.start()
            except PgUnavailable as exc:
                print(f"postgres: skipped ({exc})")
                return 0
            try:
                url = await cluster.create_database("bench_site_status")
                report("postgres", args.robots, await run(url, args.robots, args.rounds))
            finally:
                cluster.stop()
    return 0


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--robots", type=int, default=200)
    parser.add_argument("--rounds", type=int, default=10)
    parser.add_argument("--backend", choices=("sqlite", "postgres", "both"), default="sqlite")
    raise SystemExit(asyncio.run(main(parser.parse_args())))
