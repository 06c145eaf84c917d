"""Beacon tracking: smoothing, distance, removal after silence, server configuration."""

from __future__ import annotations

import asyncio
import json
import math
import random
import statistics
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from behaviours.beacons.tracker import BeaconConfig, BeaconTracker, distance_m
from drivers.ble_scanner import BleBeaconScanner
from hal.readings import BeaconSighting
from sim import vclock
from sim.devices.ble_model import SimBleAir
from sim.world.body import DiffDriveBody
from sim.world.floor_plan import World
from sim.world.geometry import Pose

UUID = "fda50693-a4e2-4fb1-afcf-c6eb07647825"
MAC = "C3:00:00:00:01:03"


def _sighting(rssi: int, t_s: float, mac: str = MAC) -> BeaconSighting:
    return BeaconSighting(mac, UUID, 1, 103, rssi, -59, t_s)


class TestDistance:
    def test_seed_formula_with_n_2(self) -> None:
        """At n = 2, 20 dB below the 1 m power is 10 m; at the 1 m power it is 1 m."""
        assert math.isclose(distance_m(-59, -79, 2.0), 10.0)
        assert math.isclose(distance_m(-59, -59, 2.0), 1.0)

    def test_larger_exponent_shortens_the_estimate(self) -> None:
        """n = 3 (indoors, obstacles) maps 30 dB to 10 m."""
        assert math.isclose(distance_m(-59, -89, 3.0), 10.0)

    def test_off_the_scale_is_infinite_not_an_error(self) -> None:
        """A tiny exponent overflows the float range: the distance is inf, nothing raises."""
        assert distance_m(-59, -127, 0.001) == math.inf

    @pytest.mark.parametrize("n", [0.0, -1.0, math.nan, math.inf])
    def test_tracker_refuses_an_unusable_exponent(self, n: float) -> None:
        """The constructor checks n like tuning does (it divides by n for every advert)."""
        with pytest.raises(ValueError, match="path_loss_exponent"):
            BeaconTracker(path_loss_exponent=n)


class TestBeaconTracker:
    def test_first_sighting_creates_an_entry_then_rssi_is_smoothed(self) -> None:
        """A jump of 10 dB moves the smoothed RSSI by 1 - exp(-dt/tau) of it."""
        tracker = BeaconTracker(smoothing_s=1.0, clock=lambda: 0.0)
        tracker.add_sighting(_sighting(-70, 0.0))
        tracker.add_sighting(_sighting(-60, 0.5))
        b = tracker.get(MAC)
        assert b is not None
        assert math.isclose(b.smoothed_rssi_dbm, -70 + 10 * (1 - math.exp(-0.5)))
        assert (b.rssi_dbm, b.sightings, b.last_seen_s) == (-60, 2, 0.5)

    def test_silent_beacon_is_removed_after_the_timeout(self) -> None:
        """A beacon is kept up to 10 s after it was last seen and dropped after that."""
        tracker = BeaconTracker(removal_timeout_s=10.0, clock=lambda: 0.0)
        tracker.add_sighting(_sighting(-70, 5.0))
        assert tracker.prune(15.0) == []
        assert tracker.prune(15.1) == [MAC]
        assert tracker.tracked() == [] and tracker.removed == 1

    def test_server_configuration_applies_to_tracked_and_later_beacons(self) -> None:
        """ActiveBeacons entries attach to beacons by MAC, whichever came first."""
        tracker = BeaconTracker(clock=lambda: 0.0)
        tracker.add_sighting(_sighting(-70, 0.0))
        problems = tracker.apply_active_beacons([
            {"MacAddress": MAC.lower(), "Name": "Room 103", "RoomName": "103",
             "RssiThreshold": -65, "IsNavigationTarget": True},
            {"MacAddress": "C3:00:00:00:00:01", "Name": "Base", "RoomName": "base",
             "RssiThreshold": None, "IsNavigationTarget": False},
            {"MacAddress": "C3:00:00:00:00:02", "RssiThreshold": "loud"},
        ])
        assert problems == ["ActiveBeacons[2].RssiThreshold: expected a number in dBm, "
                            "got 'loud'"]
        b = tracker.get(MAC)
        assert b is not None and b.config == BeaconConfig(MAC, "Room 103", "103", -65.0, True)
        tracker.add_sighting(_sighting(-80, 0.1, mac="C3:00:00:00:00:01"))
        base = tracker.get("C3:00:00:00:00:01")
        assert base is not None and base.config is not None
        assert base.config.name == "Base" and not base.is_navigation_target

    def test_a_threshold_that_is_not_finite_is_refused(self) -> None:
        """RssiThreshold NaN (Python's json reads the NaN literal) or Infinity is a bad entry:
        a NaN threshold would make arrival impossible without any message."""
        tracker = BeaconTracker(clock=lambda: 0.0)
        problems = tracker.apply_active_beacons(json.loads(
            '[{"MacAddress": "C3:00:00:00:01:03", "RssiThreshold": NaN},'
            ' {"MacAddress": "C3:00:00:00:01:04", "RssiThreshold": -Infinity}]'))
        assert [p.split(":")[0] for p in problems] == [
            "ActiveBeacons[0].RssiThreshold", "ActiveBeacons[1].RssiThreshold"]
        assert tracker.configs() == []

    def test_detected_beacons_is_the_data_exchange_list(self) -> None:
        """DetectedBeacons entries carry the contract's PascalCase fields, strongest first."""
        tracker = BeaconTracker(clock=lambda: 0.0)
        tracker.add_sighting(_sighting(-79, 0.0, mac="C3:00:00:00:00:01"))
        tracker.add_sighting(_sighting(-59, 0.0))
        assert tracker.detected_beacons() == [
            {"MacAddress": MAC, "Uuid": UUID, "Major": 1, "Minor": 103, "Rssi": -59,
             "Distance": 1.0},
            {"MacAddress": "C3:00:00:00:00:01", "Uuid": UUID, "Major": 1, "Minor": 103,
             "Rssi": -79, "Distance": 10.0}]

    def test_changing_n_recomputes_distances(self) -> None:
        """A tuned path-loss exponent applies to tracked beacons at once; 0 is refused."""
        tracker = BeaconTracker(clock=lambda: 0.0)
        tracker.add_sighting(_sighting(-89, 0.0))
        tracker.set_path_loss_exponent(3.0)
        b = tracker.get(MAC)
        assert b is not None and math.isclose(b.distance_m, 10.0)
        with pytest.raises(ValueError, match="path_loss_exponent"):
            tracker.set_path_loss_exponent(0)


def _world(beacon_x_m: float) -> World:
    return World.from_table({"width_m": 12, "height_m": 4, "beacons": [
        {"mac": MAC, "uuid": UUID, "major": 1, "minor": 103, "x_m": beacon_x_m, "y_m": 2.0,
         "tx_power_dbm": -59, "interval_s": 0.1}]})


class TestClosedLoop:
    @pytest.mark.parametrize("distance", [1.0, 2.0, 4.0, 8.0])
    def test_parked_robot_distance_estimate_is_close(self, distance: float) -> None:
        """Parked at a known distance, real driver + tracker estimate it within 25 % (mean
        of one estimate a second over 20 s); every single estimate within 60 %."""
        async def main() -> list[float]:
            body = DiffDriveBody(_world(1.0 + distance), Pose(1.0, 2.0, 0.0))
            air = SimBleAir(body, rng=random.Random(int(distance * 10)))
            scanner = BleBeaconScanner([UUID], scanner_factory=air.scanner_factory())
            tracker = BeaconTracker(scanner, smoothing_s=1.0)
            estimates = []
            async with air.running():
                await scanner.start()
                await asyncio.sleep(5)
                for _ in range(20):
                    await asyncio.sleep(1)
                    b = tracker.get(MAC)
                    assert b is not None
                    estimates.append(b.distance_m)
                await scanner.close()
            return estimates

        estimates = vclock.run(main())
        assert abs(statistics.fmean(estimates) / distance - 1) < 0.25
        assert all(abs(e / distance - 1) < 0.6 for e in estimates)

    def test_beacon_is_removed_ten_seconds_after_it_falls_silent(self) -> None:
        """A beacon whose battery dies is tracked for 10 s more, then removed."""
        async def main() -> tuple[bool, bool]:
            body = DiffDriveBody(_world(3.0), Pose(1.0, 2.0, 0.0))
            air = SimBleAir(body, rng=random.Random(5))
            scanner = BleBeaconScanner([UUID], scanner_factory=air.scanner_factory(),
                                       stall_timeout_s=600)
            tracker = BeaconTracker(scanner, removal_timeout_s=10.0)
            async with air.running():
                await scanner.start()
                pruner = asyncio.create_task(tracker.run(period_s=0.5))
                await asyncio.sleep(3)
                air.mute(MAC)
                await asyncio.sleep(9.5)
                kept = tracker.get(MAC) is not None
                await asyncio.sleep(1.5)
                gone = tracker.get(MAC) is None
                pruner.cancel()
                await scanner.close()
            return kept, gone

        assert vclock.run(main()) == (True, True)


class RecordingTelemetry:
    """An enabled ``Telemetry`` that keeps what ``values`` was given."""

    enabled = True

    def __init__(self) -> None:
        self.values_calls: list[tuple[str, dict[str, Any]]] = []

    def values(self, topic: str, /, **fields: Any) -> None:
        self.values_calls.append((topic, fields))


# One step of a tracker's life: a sighting (mac index, rssi, dt, tx power), a tuning of n, or
# n set on the attribute alone (no recomputation then: the next sighting of a beacon uses it).
_STEPS = st.one_of(
    st.tuples(st.just("see"), st.integers(0, 2), st.integers(-100, -30),
              st.floats(-0.2, 2.0), st.integers(-70, -50)),
    st.tuples(st.just("tune"), st.floats(1.0, 4.0)),
    st.tuples(st.just("set"), st.floats(1.0, 4.0)))
_MACS = ("C3:00:00:00:00:01", "c3:00:00:00:00:01", "C3:00:00:00:00:02")


class TestTrackerShortcuts:
    @given(st.lists(_STEPS, max_size=40), st.sampled_from([0.0, 0.5, 1.0]))
    def test_tracked_state_is_what_the_plain_update_gives(
            self, steps: list[tuple[Any, ...]], smoothing_s: float) -> None:
        """Smoothed RSSI, last seen, sightings and the distance (worked out when read) are
        what a plain update per sighting gives: max() for times, the distance with the n in
        force at the beacon's last sighting or tuning; a MAC in either case is one beacon."""
        tracker = BeaconTracker(smoothing_s=smoothing_s, clock=lambda: 0.0)
        model: dict[str, list[Any]] = {}  # mac -> [rssi, smoothed, last, count, tx, n]
        t_s = 0.0
        for step in steps:
            if step[0] == "see":
                _, i, rssi, dt_s, tx = step
                t_s += dt_s
                mac = _MACS[i]
                tracker.add_sighting(BeaconSighting(mac, UUID, 1, i, rssi, tx, t_s))
                m = model.get(mac.upper())
                if m is None:
                    model[mac.upper()] = [rssi, float(rssi), t_s, 1, tx,
                                          tracker.path_loss_exponent]
                    continue
                gap_s = max(0.0, t_s - m[2])
                weight = 1.0 if smoothing_s <= 0 else 1 - math.exp(-gap_s / smoothing_s)
                m[1] += (rssi - m[1]) * weight
                m[0], m[2], m[3], m[4] = rssi, max(m[2], t_s), m[3] + 1, tx
                m[5] = tracker.path_loss_exponent
            elif step[0] == "tune":
                tracker.set_path_loss_exponent(step[1])
                for m in model.values():
                    m[5] = step[1]
            else:
                tracker.path_loss_exponent = step[1]
        got = {b.mac: [b.rssi_dbm, b.smoothed_rssi_dbm, b.last_seen_s, b.sightings,
                       b.tx_power_dbm, b.distance_m] for b in tracker.tracked()}
        assert got == {mac: [*m[:5], distance_m(m[4], m[1], m[5])] for mac, m in model.items()}
        assert sorted(tracker.beacons(), key=lambda b: b.mac) == sorted(
            tracker.tracked(), key=lambda b: b.mac)

    def test_the_live_view_gets_rssi_distance_and_targets_twice_a_second(self) -> None:
        """``beacons`` values: per b<major>_<minor>, strongest first, at most every 0.5 s."""
        tracker = BeaconTracker(clock=lambda: 0.0)
        telemetry = RecordingTelemetry()
        tracker.telemetry = telemetry
        tracker.apply_config([BeaconConfig(mac="C3:00:00:00:00:01", is_navigation_target=True)])
        tracker.add_sighting(BeaconSighting("c3:00:00:00:00:01", UUID, 1, 101, -79, -59, 0.0))
        tracker.add_sighting(BeaconSighting(MAC, UUID, 1, 103, -59, -59, 0.2))
        tracker.add_sighting(BeaconSighting(MAC, UUID, 1, 103, -59, -59, 0.5))
        assert telemetry.values_calls == [
            ("beacons", {"rssi_dbm": {"b1_101": -79.0}, "distance_m": {"b1_101": 10.0},
                         "targets": ["b1_101"]}),
            ("beacons", {"rssi_dbm": {"b1_103": -59.0, "b1_101": -79.0},
                         "distance_m": {"b1_103": 1.0, "b1_101": 10.0},
                         "targets": ["b1_101"]})]
