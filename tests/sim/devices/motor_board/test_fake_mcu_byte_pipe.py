"""The in-memory serial line the fake MCU is served on."""

from __future__ import annotations

import asyncio
import random

import pytest

from sim import vclock
from sim.devices.byte_pipe import BytePipe, corrupt_bytes


class TestBytePipe:
    def test_bytes_arrive_in_order_after_their_wire_time(self) -> None:
        """At 115200 baud, 100 bytes take 100 * 10 / 115200 s; order is kept."""

        async def main() -> None:
            pipe = BytePipe(baud=115200)
            loop = asyncio.get_running_loop()
            start_s = loop.time()
            pipe.a[1].write(b"x" * 50)
            pipe.a[1].write(b"y" * 50)
            data = await pipe.b[0].readexactly(100)
            assert data == b"x" * 50 + b"y" * 50
            assert loop.time() - start_s == pytest.approx(100 * 10 / 115200)

        vclock.run(main())

    def test_delay_adds_latency_to_one_direction(self) -> None:
        """b_to_a delay 0.1 s: replies come 0.1 s late, requests do not."""

        async def main() -> None:
            pipe = BytePipe()
            pipe.b_to_a.faults.delay_s = 0.1
            loop = asyncio.get_running_loop()
            start_s = loop.time()
            pipe.a[1].write(b"ping\n")
            assert await pipe.b[0].readline() == b"ping\n"
            assert loop.time() - start_s < 0.01
            pipe.b[1].write(b"pong\n")
            assert await pipe.a[0].readline() == b"pong\n"
            assert loop.time() - start_s == pytest.approx(0.1)

        vclock.run(main())

    def test_corruption_flips_one_bit_in_about_the_given_fraction_of_bytes(self) -> None:
        """2 % of 100000 bytes: about 2000 differ, each by exactly one bit."""
        data = bytes(100_000)
        out = corrupt_bytes(data, 0.02, random.Random(1))
        changed = [b for b in out if b]
        assert 1800 < len(changed) < 2200
        assert all(bin(b).count("1") == 1 for b in changed)

    def test_corruption_in_one_direction_leaves_the_other_clean(self) -> None:
        """a_to_b corrupted 100 %: every byte to b is damaged; b to a is intact."""

        async def main() -> None:
            pipe = BytePipe(seed=3)
            pipe.a_to_b.faults.corrupt_fraction = 1.0
            pipe.a[1].write(b"A" * 10)
            pipe.b[1].write(b"B" * 10)
            assert all(c != ord("A") for c in await pipe.b[0].readexactly(10))
            assert await pipe.a[0].readexactly(10) == b"B" * 10

        vclock.run(main())

    def test_break_fails_reads_and_writes_close_gives_eof(self) -> None:
        """break_(): OSError at both ends, like a vanished USB adapter; close(): EOF."""

        async def main() -> None:
            pipe = BytePipe()
            pipe.break_()
            with pytest.raises(OSError):
                await pipe.a[0].read(10)
            with pytest.raises(OSError):
                pipe.a[1].write(b"x")
            other = BytePipe()
            other.close()
            assert await other.b[0].read(10) == b""

        vclock.run(main())
