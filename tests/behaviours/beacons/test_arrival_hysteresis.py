"""Arrival: IsInTarget from navigation-target beacons, with hysteresis against RSSI noise."""

from __future__ import annotations

import asyncio
import math
import random

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from behaviours.beacons.arrival import Arrival
from behaviours.beacons.tracker import BeaconConfig, BeaconTracker
from drivers.ble_scanner import BleBeaconScanner
from hal.readings import BeaconSighting
from sim import vclock
from sim.devices.ble_model import SimBleAir
from sim.world.body import DiffDriveBody
from sim.world.floor_plan import World
from sim.world.geometry import Pose

UUID = "fda50693-a4e2-4fb1-afcf-c6eb07647825"
TARGET = "C3:00:00:00:01:03"
OTHER = "C3:00:00:00:00:01"


def _tracker(threshold: float | None = -65.0, target: bool = True) -> BeaconTracker:
    tracker = BeaconTracker(smoothing_s=0.0, clock=lambda: 0.0)
    tracker.apply_config([BeaconConfig(TARGET, "Room 103", "103", threshold, target),
                          BeaconConfig(OTHER, "Base", "base", -90.0, False)])
    return tracker


def _see(tracker: BeaconTracker, rssi: float, t_s: float, mac: str = TARGET) -> None:
    tracker.add_sighting(BeaconSighting(mac, UUID, 1, 103, round(rssi), -59, t_s))


class TestArrival:
    def test_in_target_at_threshold_and_out_below_the_exit_margin(self) -> None:
        """Enter at RSSI >= threshold; stay down to threshold - exit margin; leave below."""
        tracker = _tracker()
        arrival = Arrival(tracker, enter_margin_db=0.0, exit_margin_db=3.0, enter_hold_s=0.0,
                          exit_hold_s=0.0)
        steps = [(-66, False), (-65, True), (-67, True), (-68, True), (-69, False),
                 (-66, False), (-65, True)]
        for t, (rssi, expected) in enumerate(steps):
            _see(tracker, rssi, float(t))
            assert arrival.update() is expected, (rssi, expected)
        assert arrival.changes == 3

    def test_only_navigation_targets_count(self) -> None:
        """A strong beacon that is not a navigation target never sets IsInTarget."""
        tracker = _tracker(target=False)
        arrival = Arrival(tracker)
        _see(tracker, -40, 0.0)
        _see(tracker, -40, 0.0, mac=OTHER)
        assert arrival.update() is False

    def test_target_without_threshold_uses_the_default(self) -> None:
        """A target the server gave no RssiThreshold uses default_threshold_dbm."""
        tracker = _tracker(threshold=None)
        arrival = Arrival(tracker, default_threshold_dbm=-60.0, enter_hold_s=0.0)
        _see(tracker, -62, 0.0)
        assert arrival.update() is False
        _see(tracker, -60, 1.0)
        assert arrival.update() is True

    def test_lost_beacon_or_cleared_target_ends_arrival(self) -> None:
        """Arrival ends when the beacon is removed or the server clears the target flag."""
        tracker = _tracker()
        arrival = Arrival(tracker, enter_hold_s=0.0)
        changes: list[bool] = []
        arrival.on_change(changes.append)
        _see(tracker, -50, 0.0)
        assert arrival.update() is True
        tracker.prune(20.0)
        assert arrival.update() is False
        _see(tracker, -50, 21.0)
        assert arrival.update() is True
        tracker.apply_config([BeaconConfig(TARGET, is_navigation_target=False)])
        assert arrival.update() is False
        assert changes == [True, False, True, False]

    @settings(max_examples=100, deadline=None)
    @given(
        start=st.floats(-95, -80),
        steps=st.lists(st.floats(0, 2.0), min_size=10, max_size=120),
        noise=st.lists(st.floats(-0.999, 0.999), min_size=120, max_size=120),
        threshold=st.floats(-75, -55),
        enter=st.floats(0, 4),
        exit_=st.floats(1, 6),
        smoothing_s=st.sampled_from([0.0, 0.5, 1.0, 3.0]),
    )
    def test_monotonic_approach_with_bounded_noise_toggles_at_most_once(
            self, start: float, steps: list[float], noise: list[float], threshold: float,
            enter: float, exit_: float, smoothing_s: float) -> None:
        """Approaching monotonically, with noise below half the hysteresis band, IsInTarget
        changes at most once (false -> true), whatever the smoothing."""
        tracker = BeaconTracker(smoothing_s=smoothing_s, clock=lambda: 0.0)
        tracker.apply_config([BeaconConfig(TARGET, rssi_threshold_dbm=threshold,
                                           is_navigation_target=True)])
        arrival = Arrival(tracker, enter_margin_db=enter, exit_margin_db=exit_)
        half_band = (enter + exit_) / 2
        true_rssi = start
        history = []
        for i, step in enumerate(steps):
            true_rssi += step
            # Whole-dBm RSSI (as adapters report) rounds by up to 0.5 dB: keep within band.
            observed = true_rssi + noise[i] * max(0.0, half_band - 0.5)
            tracker.add_sighting(BeaconSighting(TARGET, UUID, 1, 103, round(observed), -59,
                                                i * 0.1))
            history.append(arrival.update())
        assert arrival.changes <= 1
        assert history == sorted(history)


class TestArrivalClosedLoop:
    def test_robot_driving_to_the_beacon_arrives_once(self) -> None:
        """Driving straight at a beacon through the 4 dB noise of the sim, IsInTarget turns
        true once, near the distance the threshold stands for, and stays true."""
        async def main() -> tuple[list[tuple[float, bool]], float]:
            world = World.from_table({"width_m": 14, "height_m": 4, "beacons": [
                {"mac": TARGET, "uuid": UUID, "major": 1, "minor": 103, "x_m": 12.0,
                 "y_m": 2.0, "tx_power_dbm": -59}]})
            body = DiffDriveBody(world, Pose(1.0, 2.0, 0.0))
            air = SimBleAir(body, rng=random.Random(11))
            scanner = BleBeaconScanner([UUID], scanner_factory=air.scanner_factory())
            tracker = BeaconTracker(scanner, smoothing_s=1.0)
            # -65 dBm at n = 2 is 2 m from a -59 dBm beacon.
            tracker.apply_config([BeaconConfig(TARGET, rssi_threshold_dbm=-65.0,
                                               is_navigation_target=True)])
            arrival = Arrival(tracker, enter_margin_db=0.0, exit_margin_db=3.0)
            changes: list[tuple[float, bool]] = []
            arrival.on_change(lambda v: changes.append((12.0 - body.pose.x_m, v)))
            async with air.running():
                await scanner.start()
                while body.pose.x_m < 11.0:  # 0.25 m/s, updated at 10 Hz
                    body.pose = Pose(body.pose.x_m + 0.025, 2.0, 0.0)
                    await asyncio.sleep(0.1)
                    arrival.update()
                for _ in range(100):  # parked 1 m from the beacon for 10 s
                    await asyncio.sleep(0.1)
                    arrival.update()
                await scanner.close()
            return changes, arrival.changes

        changes, count = vclock.run(main())
        assert count == 1
        distance_at_arrival, value = changes[0]
        assert value is True
        assert 1.0 <= distance_at_arrival <= 3.5


class TestArrivalFromSettings:
    def test_margins_and_exponent_come_from_the_ble_section_and_tune_live(self) -> None:
        """Tracker and Arrival read the ble section; tune.set of a margin applies at once."""
        from robotd.config.loader import defaults
        from robotd.config.settings import Settings

        settings = Settings(defaults())
        tracker = BeaconTracker.from_settings(None, settings)
        arrival = Arrival.from_settings(tracker, settings)
        assert (tracker.path_loss_exponent, tracker.removal_timeout_s) == (2.0, 10.0)
        assert (arrival.enter_margin_db, arrival.exit_margin_db) == (0.0, 3.0)
        assert (arrival.enter_hold_s, arrival.exit_hold_s) == (0.5, 2.0)
        settings.set("ble.exit_margin_db", 5)
        settings.set("ble.path_loss_exponent", 2.5)
        settings.set("ble.default_rssi_threshold_dbm", -72)
        assert arrival.exit_margin_db == 5.0 and tracker.path_loss_exponent == 2.5
        assert arrival.default_threshold_dbm == -72.0


class TestArrivalParkedNearTheThreshold:
    def test_a_robot_parked_where_rssi_sits_between_the_levels_does_not_flap(self) -> None:
        """Parked 2.4 m from a -59 dBm beacon (mean -66.6 dBm, between the enter level -65
        and the exit level -68) for 10 minutes of 4 dB sim noise: with the 2 s exit hold
        IsInTarget changes a handful of times at most (without it: about 65 times)."""
        async def main(exit_hold_s: float) -> int:
            world = World.from_table({"width_m": 10, "height_m": 4, "beacons": [
                {"mac": TARGET, "uuid": UUID, "major": 1, "minor": 103, "x_m": 1.0,
                 "y_m": 2.0, "tx_power_dbm": -59}]})
            air = SimBleAir(DiffDriveBody(world, Pose(3.4, 2.0, 0.0)), rng=random.Random(1))
            scanner = BleBeaconScanner([UUID], scanner_factory=air.scanner_factory())
            tracker = BeaconTracker(scanner, smoothing_s=1.0)
            tracker.apply_config([BeaconConfig(TARGET, rssi_threshold_dbm=-65.0,
                                               is_navigation_target=True)])
            arrival = Arrival(tracker, enter_hold_s=0.0, exit_hold_s=exit_hold_s)
            async with air.running():
                await scanner.start()
                for _ in range(6000):
                    await asyncio.sleep(0.1)
                    arrival.update()
                await scanner.close()
            return arrival.changes

        assert vclock.run(main(0.0)) > 30
        assert vclock.run(main(2.0)) <= 6

    def test_exit_needs_the_rssi_below_the_exit_level_for_the_hold(self) -> None:
        """Below the exit level for less than exit_hold_s of sightings keeps the arrival;
        staying there that long ends it; a lost beacon ends it at once."""
        tracker = _tracker()
        arrival = Arrival(tracker, enter_hold_s=0.0, exit_hold_s=2.0)
        for t, rssi, expected in [(0.0, -60, True), (1.0, -70, True), (2.0, -66, True),
                                  (3.0, -70, True), (4.5, -70, True), (5.0, -70, False),
                                  (6.0, -60, True)]:
            _see(tracker, rssi, t)
            assert arrival.update() is expected, (t, rssi)
        tracker.prune(30.0)
        assert arrival.update() is False


class TestArrivalEntryHold:
    def test_entry_needs_the_rssi_at_its_level_for_the_hold(self) -> None:
        """At the level for less than enter_hold_s of sightings is not an arrival; a sighting
        below starts the hold again; held that long, it is."""
        tracker = _tracker()
        arrival = Arrival(tracker, enter_hold_s=0.5)
        for t, rssi, expected in [(0.0, -60, False), (0.3, -60, False), (0.4, -70, False),
                                  (0.5, -60, False), (0.9, -64, False), (1.0, -65, True)]:
            _see(tracker, rssi, t)
            assert arrival.update() is expected, (t, rssi)
        assert arrival.changes == 1

    def test_a_robot_passing_a_beacon_stops_near_it_despite_the_noise(self) -> None:
        """A robot driving past a room's beacon 0.35 m to its side at 0.3 m/s, through the
        sim's 4 dB noise, threshold -54 dBm (0.56 m at n = 2), 40 seeds: with the 0.5 s entry
        hold it arrives every time, within 0.45 m of the beacon. Without it the first
        sighting (nothing to smooth yet) or a noisy stretch stops it early: 2 m away in the
        worst seed."""
        async def approach(seed: int, enter_hold_s: float) -> float | None:
            world = World.from_table({"width_m": 8, "height_m": 4, "beacons": [
                {"mac": TARGET, "uuid": UUID, "major": 1, "minor": 103, "x_m": 5.0,
                 "y_m": 2.0, "tx_power_dbm": -59}]})
            body = DiffDriveBody(world, Pose(3.0, 2.35, 0.0))
            air = SimBleAir(body, rng=random.Random(seed))
            scanner = BleBeaconScanner([UUID], scanner_factory=air.scanner_factory())
            tracker = BeaconTracker(scanner, smoothing_s=1.0)
            tracker.apply_config([BeaconConfig(TARGET, rssi_threshold_dbm=-54.0,
                                               is_navigation_target=True)])
            arrival = Arrival(tracker, enter_hold_s=enter_hold_s)
            async with air.running():
                await scanner.start()
                while body.pose.x_m < 6.0 and not arrival.update():
                    body.pose = Pose(body.pose.x_m + 0.03, 2.35, 0.0)
                    await asyncio.sleep(0.1)
                await scanner.close()
            if not arrival.is_in_target:
                return None
            return math.hypot(body.pose.x_m - 5.0, 0.35)

        held = [vclock.run(approach(seed, 0.5)) for seed in range(40)]
        bare = [vclock.run(approach(seed, 0.0)) for seed in range(40)]
        assert None not in held and None not in bare
        assert max(d for d in held if d is not None) <= 0.45
        assert max(d for d in bare if d is not None) > 1.0


class _Logged(Arrival):
    """Arrival whose updates are written into a shared log (what ran, in which order)."""

    def __init__(self, log: list[tuple[str, float]], *, fail_at: int = -1) -> None:
        super().__init__(_tracker())
        self.log = log
        self.fail_at = fail_at

    def update(self) -> bool:
        self.log.append(("update", asyncio.get_running_loop().time()))
        if len(self.log) == self.fail_at:
            raise RuntimeError("update failed")
        return super().update()


class _SleepPaced(_Logged):
    """The plain loop ``Arrival.run`` stands for."""

    async def run(self, period_s: float = 0.1) -> None:
        while True:
            await asyncio.sleep(period_s)
            self.update()


def _timeline(cls: type[_Logged], period_s: float, others: list[float], cancel_s: float,
              fail_at: int) -> tuple[list[tuple[str, float]], str]:
    """Updates, other tasks' sleeps and bare timers interleaved, until a timer cancels."""
    log: list[tuple[str, float]] = []

    async def sleeper(name: str, every_s: float) -> None:
        while True:
            await asyncio.sleep(every_s)
            log.append((name, asyncio.get_running_loop().time()))

    async def main() -> str:
        loop = asyncio.get_running_loop()
        arrival = cls(log, fail_at=fail_at)
        task = asyncio.create_task(arrival.run(period_s))
        helpers = [asyncio.create_task(sleeper(f"task{i}", s)) for i, s in enumerate(others)]
        for i, s in enumerate(others):
            for k in range(1, 6):
                loop.call_at(k * s, lambda name=f"timer{i}": log.append(
                    (name, asyncio.get_running_loop().time())))
        loop.call_at(cancel_s, task.cancel)
        try:
            await task
            outcome = "returned"
        except asyncio.CancelledError:
            outcome = "cancelled"
        except RuntimeError as exc:
            outcome = str(exc)
        for helper in helpers:
            helper.cancel()
        return outcome

    return log, vclock.run(main())


class TestArrivalPacing:
    @settings(max_examples=60, deadline=None)
    @given(st.sampled_from([0.05, 0.1, 0.2, 0.3]),
           st.lists(st.sampled_from([0.05, 0.1, 0.2, 0.25]), max_size=3),
           st.sampled_from([0.1, 0.2, 0.3, 0.45, 0.6, 1.0]), st.integers(-1, 12))
    def test_runs_as_the_sleeping_loop_would(self, period_s: float, others: list[float],
                                             cancel_s: float, fail_at: int) -> None:
        """Updates come at the same instants, in the same order among other tasks and
        timers due then, stop when the run is cancelled (also from a timer due with one),
        and an exception from update ends the run with it, as a sleeping loop's would."""
        assert _timeline(_Logged, period_s, others, cancel_s, fail_at) == \
            _timeline(_SleepPaced, period_s, others, cancel_s, fail_at)

    @pytest.mark.parametrize("period_s", [0.0, -0.1, math.nan])
    def test_a_period_that_is_not_positive_is_refused(self, period_s: float) -> None:
        """run() needs a period > 0 s (0 would take every loop turn and stop virtual time)."""
        with pytest.raises(ValueError, match="period_s"):
            vclock.run(Arrival(_tracker()).run(period_s))
