"""A reconnect storm (seed section 13): 500 robots back online at once are all restored, in a
few batched transactions, with nothing lost."""

from __future__ import annotations

import asyncio
import time

from fleet_harness import SITE_TOML, Fleet, beacon, token_for

ROBOTS = [f"storm-{i:03d}" for i in range(500)]
STORM_SITE = SITE_TOML + "".join(f"""
[[robots]]
name = "{name}"

[[tokens]]
role = "robot"
subject = "{name}"
token = "{token_for('robot', name)}"
""" for name in ROBOTS)


class TestReconnectStorm:
    async def test_500_robots_back_at_once_all_end_up_online(self, db_url):
        """Every robot is online again, each request keeps its status and loses its offline
        alert, one reconnect notice per robot, and far fewer transactions than robots."""
        async with Fleet(db_url, site_toml=STORM_SITE) as fleet:
            request = await fleet.request(1)  # robot-1 takes it, then holds the laundry
            await fleet.arrive_at_room("robot-1", 1, weight_kg=3.0)
            await fleet.do(request["Id"], "confirm-loaded")
            everyone = ["robot-1", "robot-2", *ROBOTS]
            await asyncio.gather(*(fleet.exchange(name) for name in everyone))
            fleet.clock.advance(31)
            went = await fleet.server.check_offline()
            assert sorted(went) == sorted(everyone)
            assert (await fleet.get(request["Id"]))["AdminAlert"] is not None

            batches_before = fleet.server.views.reconnects.batches  # first reports' batches
            started = time.perf_counter()
            replies = await asyncio.gather(*(fleet.exchange(name) for name in everyone))
            elapsed_s = time.perf_counter() - started

            assert len(replies) == len(everyone)
            robots = await fleet.robots()
            assert [n for n in everyone if robots[n]["IsOffline"]] == []
            after = await fleet.get(request["Id"])
            assert (after["Status"], after["AdminAlert"]) == ("LaundryLoaded", None)
            notices = await fleet.notifications(recipient="admin", limit=1000)
            back = [n["RobotName"] for n in notices if n["Kind"] == "robot.reconnected"]
            assert sorted(back) == sorted(everyone)
            # How many exchanges share a transaction depends on how fast the database answers
            # (2-5 on a quiet machine, 40 seen with the 2 cores busy): a tenth of the robots at
            # most is still "far fewer transactions than robots" on a loaded CI machine.
            batches = fleet.server.views.reconnects.batches - batches_before
            assert batches <= len(everyone) // 10
            print(f"\nreconnect storm: {len(everyone)} robots restored in {elapsed_s:.2f} s, "
                  f"{batches} transactions")
            # The robot with laundry goes on to base as before.
            await fleet.exchange("robot-1", beacons=[beacon("C3:00:00:00:00:01")],
                                 in_target=True, weight_kg=3.0)
            assert await fleet.status(request["Id"]) == "Washing"


class TestReconnectFailure:
    async def test_a_failed_batch_fails_its_waiters_and_the_next_one_runs(self, fleet):
        """A batch whose transaction fails answers its robots with the error (they report
        again a second later); the batcher does not spin, and the next batch works."""
        from fleet.services.reconnect import Reconnects

        calls: list[str] = []

        def apply(_robot, _now, report: str) -> None:
            calls.append(report)
            if report == "bad":
                raise RuntimeError("disk full")

        reconnects: Reconnects[str] = Reconnects(fleet.server.db, fleet.clock, apply)
        results = await asyncio.gather(reconnects.restore("robot-1", "bad"),
                                       return_exceptions=True)
        assert isinstance(results[0], RuntimeError)
        await reconnects.restore("robot-1", "good")
        assert calls == ["bad", "good"]
        assert reconnects.batches == 1
