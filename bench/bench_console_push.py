"""The console's pollers on the event hub: what one pass costs with N robots (issue 29).

While a staff page listens, each server process reads every robot's view once a pass
(``fleet.console.robot_push.RobotChanges``, at most twice a second) and, while a customer page
listens, the active requests (``RequestChanges``). This times one pass, nothing changed (the
common case), on SQLite in one process, beside a plain read of the robots table in the same
run (the database's own cost), for 100, 500 and 2000 robots, half of them serving a request.
With ``--reporting F`` that fraction of the robots (those serving no request) report a site
status instead (a vacuum's: profile, pose on ``odom``), read through ``robot_statuses``.

    .venv/bin/python bench/bench_console_push.py [--robots 100,500,2000] [--passes 200]
        [--reporting 0.5]
"""

from __future__ import annotations

import argparse
import asyncio
import statistics
import sys
import tempfile
import time
from collections.abc import Awaitable, Callable
from pathlib import Path

from sqlalchemy import select, update

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from fleet.console.request_push import RequestChanges  # noqa: E402
from fleet.console.robot_push import RobotChanges  # noqa: E402
from fleet.models import Request, Robot  # noqa: E402
from fleet.server import FleetServer  # noqa: E402
from fleet.site import parse_site  # noqa: E402


def site_toml(robots: int) -> str:
    rooms = "".join(f'[[rooms]]\nname = "Room {i}"\n' for i in range(robots // 2))
    beacons = "".join(f'[[beacons]]\nmac = "C3:00:00:00:{i // 256:02X}:{i % 256:02X}"\n'
                      f'name = "room-{i}"\nroom = "Room {i}"\n' for i in range(robots // 2))
    customers = "".join(f'[[customers]]\nid = {i + 1}\nname = "C{i}"\n'
                        f'beacon = "C3:00:00:00:{i // 256:02X}:{i % 256:02X}"\n'
                        for i in range(robots // 2))
    fleet = "".join(f'[[robots]]\nname = "robot-{i}"\n' for i in range(robots))
    return ('[[rooms]]\nname = "Laundry"\n[[beacons]]\nmac = "C3:00:00:00:FF:FF"\n'
            'name = "base"\nroom = "Laundry"\nbase = true\n'
            + rooms + beacons + customers + fleet)


async def _timed(call: Callable[[], Awaitable[object]], passes: int) -> tuple[float, float]:
    times = []
    for _ in range(passes):
        start = time.perf_counter()
        await call()
        times.append((time.perf_counter() - start) * 1000)
    times.sort()
    return statistics.median(times), times[int(len(times) * 0.99) - 1]


async def bench(robots: int, passes: int, reporting: float = 0.0) -> None:
    with tempfile.TemporaryDirectory() as folder:
        server = FleetServer(f"sqlite:///{folder}/fleet.db",
                             site=parse_site(site_toml(robots), "bench"))
        await server.start(monitors=False)
        now = server.clock()
        async with server.db.write() as session:
            await session.execute(update(Robot).values(is_offline=False, last_ping_at=now,
                                                       state="mission.to_room",
                                                       battery_pct=80.0))
            for i in range(robots // 2):
                session.add(Request(customer_id=i + 1, status="Accepted", is_approved=True,
                                    created_at=now, status_changed_at=now))
            await session.flush()
            ids = (await session.execute(select(Request.id).order_by(Request.id))).scalars()
            for i, request_id in enumerate(list(ids)):
                await session.execute(update(Robot).where(Robot.name == f"robot-{i}")
                                      .values(current_request_id=request_id))
            for i in range(robots - int(robots * reporting), robots):
                await session.execute(update(Robot).where(Robot.name == f"robot-{i}").values(
                    status_at=now, profile="vacuum", pose_x_m=1.0, pose_y_m=2.0,
                    pose_theta_rad=0.5, map_name="odom"))

        async def plain() -> None:
            async with server.db.read() as session:
                (await session.execute(select(Robot))).scalars().all()

        robot_changes = RobotChanges(server.db, server.clock)
        request_changes = RequestChanges(server.db, server.clock)
        await robot_changes()  # the first pass sends every robot; the rest nothing
        await request_changes()
        base = await _timed(plain, passes)
        views = await _timed(robot_changes, passes)
        requests = await _timed(request_changes, passes)
        await server.stop()
    print(f"{robots:5d} robots ({reporting:.0%} site status)"
          f"  robots table read p50 {base[0]:6.2f} ms p99 {base[1]:6.2f} ms"
          f" | robots pass p50 {views[0]:6.2f} ms p99 {views[1]:6.2f} ms"
          f" | requests pass p50 {requests[0]:6.2f} ms p99 {requests[1]:6.2f} ms")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", default="100,500,2000")
    parser.add_argument("--passes", type=int, default=200)
    parser.add_argument("--reporting", type=float, default=0.0,
                        help="the fraction of robots that report a site status")
    args = parser.parse_args()
    for robots in (int(n) for n in args.robots.split(",")):
        asyncio.run(bench(robots, args.passes, args.reporting))


if __name__ == "__main__":
    main()
