"""Waiting for DOUT on its falling edge reads at the very instants polling reads at."""

from __future__ import annotations

import asyncio
import random
from dataclasses import dataclass, field
from typing import Any

import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from drivers.hx711 import Hx711
from drivers.hx711_ready import wait_dout_low
from hal.ports import DoutAlert
from sim import vclock
from sim.devices.hx711_model import SimHx711Lines

_TURN_S = 1e-9  # the virtual-time loop runs timers due within 1 ns in one turn


def _gap_s(most_s: float) -> st.SearchStrategy[float]:
    """A fault's length: none, or at least a loop turn. A wire pulled and put back less than
    1 ns apart is switched twice within one turn of the loop, and which of a poll and the
    switches comes first in that turn is the order the timers were set in: polling may then
    read one 2 ms step after the edge wait (found by Hypothesis: 1e-12 s at t = 1 s)."""
    return st.one_of(st.just(0.0), st.floats(_TURN_S, most_s))


class PollOnly:
    """The same simulated lines without ``on_dout_low``: the driver has to poll."""

    def __init__(self, lines: SimHx711Lines) -> None:
        self._lines = lines

    def set_sck(self, high: bool) -> None:
        self._lines.set_sck(high)

    def read_dout(self) -> bool:
        return self._lines.read_dout()

    def now_us(self) -> int:
        return self._lines.now_us()


@dataclass
class Run:
    """What one run saw: when each conversion was read, what was published, the counts."""

    read_at_s: list[float] = field(default_factory=list)
    published: list[tuple[float, int]] = field(default_factory=list)
    counts: dict[str, int] = field(default_factory=dict)
    sim_counts: tuple[int, ...] = ()


async def _at(t_s: float, action: Any) -> None:
    loop = asyncio.get_running_loop()
    await asyncio.sleep(max(0.0, t_s - loop.time()))
    action()


def _run(edges: bool, sps: int, seconds: float, faults: dict[str, float]) -> Run:
    """The real driver on the simulated chip for ``seconds`` of virtual time, with faults
    switched at the given times and a ticker of its own beside it."""
    run = Run()

    async def main() -> None:
        loop = asyncio.get_running_loop()
        load = {"kg": 1.5}

        def weight() -> float:  # the chip samples the load once per conversion read
            run.read_at_s.append(loop.time())
            return load["kg"]

        sim = SimHx711Lines(weight_kg=weight, sps=sps, rng=random.Random(5))
        hx = Hx711(lambda: sim if edges else PollOnly(sim), sps=sps, timeout_s=0.5)

        async def ticker() -> None:  # other work on the loop, on a grid of its own
            for _ in range(100_000):
                await asyncio.sleep(0.0071234)

        def heavier() -> None:
            load["kg"] = 3.0

        actions = {"disconnect": sim.disconnect, "connect": sim.connect,
                   "lose_gpio": sim.lose_gpio, "restore_gpio": sim.restore_gpio,
                   "spike": lambda: sim.spike_next_conversion(900_000), "heavier": heavier}
        await hx.start()
        async with asyncio.TaskGroup() as group:
            tasks = [group.create_task(ticker())]
            tasks += [group.create_task(_at(t, actions[name])) for name, t in faults.items()]
            end = loop.time() + seconds
            while loop.time() < end:
                try:
                    reading = await asyncio.wait_for(hx.next_reading(), end - loop.time())
                except TimeoutError:
                    break
                run.published.append((reading.t_s, reading.raw))
            for task in tasks:
                task.cancel()
        await hx.close()
        run.counts = dict(hx.counts)
        run.sim_counts = (sim.reads_started, sim.reads_completed, sim.power_downs)

    vclock.run(main())
    return run


class TestEdgeWaitMatchesPolling:
    def test_the_sim_lines_offer_the_alert(self) -> None:
        """``SimHx711Lines`` is a ``DoutAlert``; the poll-only wrapper is not."""
        sim = SimHx711Lines(weight_kg=lambda: 0.0)
        assert isinstance(sim, DoutAlert) and not isinstance(PollOnly(sim), DoutAlert)

    def test_same_reads_at_the_same_instants(self) -> None:
        """Ten seconds at 10 SPS: every conversion read at the same instant, same readings."""
        polled = _run(False, 10, 10.0, {})
        edged = _run(True, 10, 10.0, {})
        assert len(polled.read_at_s) >= 95
        assert edged.read_at_s == polled.read_at_s
        assert edged.published == polled.published
        assert edged.counts == polled.counts

    def test_each_weight_is_published_most_of_a_period_after_its_read(self) -> None:
        """A conversion read at t is filtered and published at t + 0.8 periods (the reader
        sleeps through most of the next conversion), the first one after start-up dropped."""
        for sps in (10, 80):
            run = _run(True, sps, 3.0, {})
            published_s = [t_s for t_s, _ in run.published]
            assert len(published_s) >= 2 * sps
            period_s = 1.0 / sps
            assert published_s == [t + period_s * 0.8 for t in run.read_at_s[1:]][
                :len(published_s)]

    @settings(max_examples=25, deadline=None)
    @example(sps=10, cut=1.0, cut_s=1.0, lost=3.0, lost_s=0.0, heavier=1.0, spike=1.0)
    @given(sps=st.sampled_from([10, 80]),
           cut=st.floats(0.5, 2.0), cut_s=_gap_s(1.5),
           lost=st.floats(2.5, 3.5), lost_s=_gap_s(1.0),
           heavier=st.floats(0.2, 4.0), spike=st.floats(0.2, 4.0))
    def test_same_instants_through_faults(self, sps: int, cut: float, cut_s: float,
                                          lost: float, lost_s: float, heavier: float,
                                          spike: float) -> None:
        """A pulled DOUT wire (timeouts), a lost GPIO chip (line errors), a load change and a
        spike: the edge-waiting driver reads, times out and fails at the instants polling
        does (to the loop's turn), and publishes the same readings."""
        faults = {"disconnect": cut, "connect": cut + cut_s, "lose_gpio": lost,
                  "restore_gpio": lost + lost_s, "heavier": heavier, "spike": spike}
        polled = _run(False, sps, 5.0, faults)
        edged = _run(True, sps, 5.0, faults)
        # A switch at a grid instant (within the loop's 1 ns) runs in the same loop turn as
        # a poll: the polling read then sees the merged turn's clock, a few ulp away.
        assert len(edged.read_at_s) == len(polled.read_at_s)
        assert all(abs(e - p) < _TURN_S for e, p in zip(edged.read_at_s, polled.read_at_s,
                                                         strict=True))
        assert [raw for _, raw in edged.published] == [raw for _, raw in polled.published]
        assert edged.counts == polled.counts
        assert edged.sim_counts == polled.sim_counts


class TestWaitDoutLow:
    @given(timeout_s=st.floats(0.0, 0.05))
    def test_times_out_on_the_poll_grid(self, timeout_s: float) -> None:
        """A wire that never goes low: False at the first grid instant at or after the
        deadline, the instant polling gives up at."""
        def timed(edges: bool) -> tuple[bool, float, float]:
            async def main() -> tuple[bool, float, float]:
                loop = asyncio.get_running_loop()
                await asyncio.sleep(0.3)
                sim = SimHx711Lines(weight_kg=lambda: 0.0)
                sim.disconnect()
                start = loop.time()
                ok = await wait_dout_low(sim if edges else PollOnly(sim), timeout_s)
                return ok, start, loop.time()

            result: tuple[bool, float, float] = vclock.run(main())
            return result

        ok, start, end = timed(edges=True)
        assert (ok, start, end) == timed(edges=False)
        expected = start
        while expected < start + timeout_s:
            expected += 0.002
        assert not ok and end == expected


class TestWaitFrom:
    @settings(max_examples=40, deadline=None)
    @given(edges=st.booleans(), sps=st.sampled_from([10, 80]), start_s=st.floats(0.0, 0.6),
           from_after_s=st.floats(0.0, 0.3), timeout_s=st.floats(0.0, 0.3),
           cut=st.sampled_from([None, 0.05, 0.2]))
    @example(edges=False, sps=10, start_s=0.0, from_after_s=0.21798145457555648, timeout_s=0.0,
             cut=0.05)  # the clock a unit in the last place short of the deadline
    def test_waiting_from_a_later_instant_is_sleeping_until_it_then_waiting(
            self, edges: bool, sps: int, start_s: float, from_after_s: float, timeout_s: float,
            cut: float | None) -> None:
        """``wait_dout_low(from_s=t)`` started early gives what sleeping until ``t`` and then
        waiting gives: the same answer at the same instant, with the timeout counted from
        ``t``, also when the DOUT wire is pulled in between."""
        def timed(early: bool) -> tuple[bool, float]:
            async def main() -> tuple[bool, float]:
                loop = asyncio.get_running_loop()
                sim = SimHx711Lines(weight_kg=lambda: 1.0, sps=sps, clock=loop.time)
                lines = sim if edges else PollOnly(sim)
                await asyncio.sleep(start_s)
                from_s = loop.time() + from_after_s
                if cut is not None:
                    loop.call_at(loop.time() + cut, sim.disconnect)
                if early:
                    ok = await wait_dout_low(lines, timeout_s, from_s=from_s)
                else:
                    await asyncio.sleep(from_s - loop.time())
                    ok = await wait_dout_low(lines, timeout_s)
                return ok, loop.time()

            result: tuple[bool, float] = vclock.run(main())
            return result

        early, late = timed(early=True), timed(early=False)
        assert early[0] == late[0]
        # The same instant: the late path's ``sleep(t - now)`` lands on ``now + (t - now)``,
        # which can differ from ``t`` in the last bit (Hypothesis: 0.21798145457555648).
        assert early[1] == pytest.approx(late[1], rel=1e-12, abs=1e-12)
