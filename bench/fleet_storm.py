"""The fleet server's reconnect storm, for bench/bench_fleet.py ``--storm``.

Every robot reports, goes offline (OfflineAfterS 2 s, checked every second), then all report
at once on connections opened beforehand; prints how long until the last one is answered
(restored), and checks that all are online after. Target: 500 robots restored within 1 s.
"""

from __future__ import annotations

import asyncio
import json
import time

from bench_fleet import Conn, exchange_body, robot_token, served_fleet, with_state


async def run_storm(db_url: str, robots: int, port: int,
                    extra: tuple[str, ...] = ()) -> dict[str, float]:
    """A reconnect storm: every robot reports, goes offline (OfflineAfterS 2 s, checked every
    second), then all report at once on connections opened beforehand. Returns the seconds
    from the first send to the last answer, and how many robots are online after."""
    # OfflineAfterS only once the requests are made: robots are online until then.
    async with served_fleet(db_url, robots, port, extra, "OfflineCheckPeriodS = 1\n",
                            after={"OfflineAfterS": 2}) as (admin, _pid):
        # Another process's state, seen only through its API: poll it.
        while sum(r["IsOffline"] for r in await _robots(admin)) < robots:  # noqa: ASYNC110
            await asyncio.sleep(0.5)
        # Keep them online once back (the storm, not the monitor, is measured).
        await admin.call("PUT", "/api/settings", json.dumps({"OfflineAfterS": 3600}).encode())
        conns = [Conn(port) for _ in range(robots)]  # opened now: idle ones time out
        for conn in conns:
            await conn.connect()
        started = time.perf_counter()
        answers = await asyncio.gather(*(
            conn.call("POST", f"/api/Robot/robot-{i}/data-exchange",
                      exchange_body(f"robot-{i}", i, state=with_state(i)), robot_token(i))
            for i, conn in enumerate(conns)))
        elapsed_s = time.perf_counter() - started
        bad = [status for status, _ in answers if status != 200]
        if bad:
            msg = f"{len(bad)} storm answers were not 200, e.g. {bad[0]}"
            raise RuntimeError(msg)
        online = sum(not r["IsOffline"] for r in await _robots(admin))
        for conn in conns:
            conn.close()
        admin.close()
        return {"restore_s": elapsed_s, "online": online}


async def _robots(admin: Conn) -> list[dict[str, object]]:
    status, body = await admin.call("GET", "/api/robots")
    assert status == 200, body
    robots: list[dict[str, object]] = json.loads(body)
    return robots


def report_storm(backend: str, robots: int, r: dict[str, float]) -> None:
    print(f"{backend:10s} robots={robots:4d}  reconnect storm restored in "
          f"{r['restore_s'] * 1000:.0f} ms; online after: {int(r['online'])}/{robots}",
          flush=True)


