"""The motor board's docking additions (issue 15), checked against every MCU endpoint.

``IRS``, ``DOCK``, ``BUMP``, ``WALL`` and ``BIN`` telemetry reach the real driver's dock feeds,
in both framings; ``EVAC:<0|1>`` reaches the station output and a bad one is refused.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from functools import partial

import pytest
from endpoints import ENDPOINTS, McuEndpoint, Scenario, run_scenario

from drivers.arduino import ArduinoLink, Framing, Outcome

Runner = Callable[[Scenario], None]


@pytest.fixture(params=sorted(ENDPOINTS))
def run(request: pytest.FixtureRequest) -> Runner:
    return partial(run_scenario, ENDPOINTS[request.param])


async def wait_until(predicate: Callable[[], bool], timeout_s: float = 2.0) -> None:
    """Polls: what it waits on is a record of the plant or of a feed, not an event of ours."""
    async with asyncio.timeout(timeout_s):
        while not predicate():  # noqa: ASYNC110 - three kinds of endpoint, no common event
            await asyncio.sleep(0.02)


async def check_dock_feeds(link: ArduinoLink) -> None:
    """The feeds carry what the bench set (the firmware's ADCs quantise: small slack)."""
    dock = link.dock
    await wait_until(lambda: all(feed.latest() is not None for feed in (
        dock.signal, dock.contacts, dock.bumpers, dock.wall, dock.bin)))
    signal = await asyncio.wait_for(dock.signal.next_reading(), 1.0)
    assert (signal.front_left, signal.front_right) == (612, 580)
    contacts = await asyncio.wait_for(dock.contacts.next_reading(), 1.0)
    assert contacts.mv == pytest.approx(16_800, abs=60)
    bumpers = await asyncio.wait_for(dock.bumpers.next_reading(), 2.0)
    assert (bumpers.left, bumpers.right) == (True, False)
    wall = await asyncio.wait_for(dock.wall.next_reading(), 1.0)
    assert wall.distance_cm == pytest.approx(12.0, abs=1.0)
    bin_level = await asyncio.wait_for(dock.bin.next_reading(), 2.0)
    assert bin_level.percent == pytest.approx(40.0, abs=1.0)
    assert link.status()["bad_telemetry"] == 0


class TestDockTelemetry:
    @pytest.mark.parametrize("framing", [Framing.CRC, Framing.PLAIN])
    def test_docking_sensors_reach_the_dock_feeds(self, run: Runner, framing: Framing) -> None:
        """IRS, DOCK, BUMP, WALL and BIN become readings of link.dock's feeds."""

        async def scenario(ep: McuEndpoint) -> None:
            ep.set_dock_inputs(signal=(612, 580), contact_mv=16_800, bumpers=(True, False),
                               wall_cm=12.0, bin_pct=40.0)
            link = ep.link(framing=framing)
            await link.start()
            try:
                if framing is Framing.PLAIN:
                    assert (await link.command("HB")).ok  # telemetry follows the last command
                await check_dock_feeds(link)
            finally:
                await link.close()

        run(scenario)

    def test_irs_comes_at_20_hz_and_a_bumper_change_at_once(self, run: Runner) -> None:
        """About 20 IRS readings a second; a bumper pressed shows within 100 ms."""

        async def scenario(ep: McuEndpoint) -> None:
            ep.set_dock_inputs(signal=(100, 200), bumpers=(False, False))
            link = ep.link()
            await link.start()
            try:
                loop = asyncio.get_running_loop()
                await wait_until(lambda: link.dock.bumpers.latest() is not None)
                seen: list[float] = []
                stop = link.dock.signal.listen(lambda r: seen.append(r.t_s))
                await asyncio.sleep(1.0)
                stop()
                assert 17 <= len(seen) <= 23
                ep.set_dock_inputs(bumpers=(False, True))
                pressed_s = loop.time()
                await wait_until(lambda: (b := link.dock.bumpers.latest()) is not None
                                 and b.right, timeout_s=1.0)
                assert loop.time() - pressed_s <= 0.1 + ep.timing_slack_s
            finally:
                await link.close()

        run(scenario)


class TestEvac:
    def test_evacuate_switches_the_station_output(self, run: Runner) -> None:
        """evacuate(True) then evacuate(False): the EVAC output goes on, then off."""

        async def scenario(ep: McuEndpoint) -> None:
            link = ep.link()
            await link.start()
            try:
                await link.evacuate(True)
                await wait_until(lambda: ep.evac_log() == [True])
                await link.evacuate(False)
                await wait_until(lambda: ep.evac_log() == [True, False])
            finally:
                await link.close()

        run(scenario)

    def test_a_bad_evac_is_refused_and_changes_nothing(self, run: Runner) -> None:
        """EVAC:2 gets NAK:RANGE, EVAC: and EVAC:on NAK:PARSE; the output stays off."""

        async def scenario(ep: McuEndpoint) -> None:
            link = ep.link()
            await link.start()
            try:
                cases = {"EVAC:2": "NAK:RANGE", "EVAC:": "NAK:PARSE", "EVAC:on": "NAK:PARSE"}
                for payload, reason in cases.items():
                    delivery = await link.command(payload)
                    assert (delivery.outcome, delivery.detail) == (Outcome.NAK, reason), payload
                await asyncio.sleep(0.2)
                assert ep.evac_log() == []
            finally:
                await link.close()

        run(scenario)
