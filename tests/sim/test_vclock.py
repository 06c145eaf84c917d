"""The virtual-time event loop: jumps to the next timer, holds for outside work."""

from __future__ import annotations

import asyncio
import time

from sim import vclock


class TestVirtualTimeLoop:
    def test_an_hour_of_sleep_takes_no_wall_time(self) -> None:
        """Virtual time jumps straight to the timer."""

        async def main() -> float:
            await asyncio.sleep(3600)
            return asyncio.get_running_loop().time()

        start = time.monotonic()
        assert vclock.run(main()) == 3600.0
        assert time.monotonic() - start < 30  # generous: only guards against real sleeping

    def test_timers_fire_in_order_at_their_times(self) -> None:
        async def main() -> list[tuple[str, float]]:
            loop = asyncio.get_running_loop()
            seen: list[tuple[str, float]] = []

            async def tick(name: str, period: float, n: int) -> None:
                for _ in range(n):
                    await asyncio.sleep(period)
                    seen.append((name, round(loop.time(), 9)))

            await asyncio.gather(tick("a", 0.3, 3), tick("b", 0.5, 2))
            return seen

        assert vclock.run(main()) == [("a", 0.3), ("b", 0.5), ("a", 0.6), ("a", 0.9),
                                      ("b", 1.0)]

    def test_executor_work_holds_the_clock(self) -> None:
        """A timeout does not fire while a thread is still working (time is held)."""

        async def main() -> float:
            loop = asyncio.get_running_loop()
            before = loop.time()
            await asyncio.wait_for(loop.run_in_executor(None, time.sleep, 0.05), 0.01)
            return loop.time() - before

        assert vclock.run(main()) == 0.0

    def test_speed_mode_follows_the_wall_clock(self) -> None:
        async def main() -> float:
            loop = asyncio.get_running_loop()
            before = loop.time()
            await asyncio.sleep(0.5)
            return loop.time() - before

        assert vclock.run(main(), speed=10.0) >= 0.5

    def test_real_sockets_still_work(self) -> None:
        """I/O on real file descriptors is polled while virtual time runs."""

        async def main() -> bytes:
            async def echo(r: asyncio.StreamReader, w: asyncio.StreamWriter) -> None:
                w.write(await r.readline())
                await w.drain()
                w.close()

            server = await asyncio.start_server(echo, "127.0.0.1", 0)
            port = server.sockets[0].getsockname()[1]
            reader, writer = await asyncio.open_connection("127.0.0.1", port)
            writer.write(b"ping\n")
            line = await asyncio.wait_for(reader.readline(), 5)
            writer.close()
            server.close()
            return line

        assert vclock.run(main()) == b"ping\n"

    def test_timers_set_for_the_same_moment_run_in_the_order_they_were_set(self) -> None:
        async def main() -> list[int]:
            loop = asyncio.get_running_loop()
            seen: list[int] = []
            for i in range(50):
                loop.call_at(1.0, seen.append, i)
            await asyncio.sleep(2)
            return seen

        assert vclock.run(main()) == list(range(50))

    def test_cancelled_timers_never_run_and_do_not_pile_up(self) -> None:
        """Cancelling many timers (resend deadlines, deadmen) leaves a short queue."""

        async def main() -> tuple[list[int], int]:
            loop = asyncio.get_running_loop()
            seen: list[int] = []
            for i in range(1000):
                loop.call_later(10.0 + i, seen.append, i).cancel()
            loop.call_later(5.0, seen.append, -1)
            await asyncio.sleep(1)
            return seen, len(loop._scheduled)  # type: ignore[attr-defined]

        seen, queued = vclock.run(main())
        assert seen == []
        assert queued < 10

    def test_a_failing_callback_goes_to_the_exception_handler(self) -> None:
        """The loop carries on; the handler hears which callback failed and why."""

        async def main() -> list[dict[str, object]]:
            loop = asyncio.get_running_loop()
            heard: list[dict[str, object]] = []
            loop.set_exception_handler(lambda _loop, context: heard.append(context))

            def fail() -> None:
                raise ValueError("boom")

            loop.call_soon(fail)
            loop.call_later(0.5, fail)
            await asyncio.sleep(1)
            return heard

        heard = vclock.run(main())
        assert len(heard) == 2
        assert all(isinstance(h["exception"], ValueError) for h in heard)
        assert "fail" in str(heard[0]["message"])

    def test_debug_mode_runs_the_same_timers(self) -> None:
        async def main() -> list[tuple[str, float]]:
            loop = asyncio.get_running_loop()
            loop.set_debug(True)
            seen: list[tuple[str, float]] = []
            loop.call_later(0.2, lambda: seen.append(("b", loop.time())))
            loop.call_at(0.1, lambda: seen.append(("a", loop.time())))
            loop.call_soon(lambda: seen.append(("now", loop.time())))
            await asyncio.sleep(0.3)
            return seen

        assert vclock.run(main()) == [("now", 0.0), ("a", 0.1), ("b", 0.2)]
