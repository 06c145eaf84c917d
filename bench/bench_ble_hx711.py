"""Cost of the BLE and HX711 paths, and what they do to a 13 FPS control loop's timing.

Prints:
- per advert: bleak's callback path + iBeacon parse + tracker update (p50/p99 us), next to the
  parse alone measured in the same run;
- the simulator's BLE pipeline as in ``laundry`` (two robots, 5 beacons each at 10 Hz, 351
  virtual s on the virtual-time loop): CPU per advert sent, built up stage by stage (the air
  alone, + bleak with a no-op callback, + the scanner driver, + the tracker and its 2 Hz live
  view, + arrival at 10 Hz); ``--pipeline-only`` prints just these;
- per HX711 read: the synchronous 25-pulse bit-bang against the simulated chip (p50/p99 us);
  this is how long one read holds the event loop (on a Pi, lgpio calls cost more);
- the laundry robots' weighing alone: two HX711 drivers at 10 SPS on simulated chips, each
  read by a ``LoadCheck``, for 351 virtual s (the ``laundry`` run) on the virtual-time loop:
  the CPU seconds it takes, wake-ups and all (best of 3);
- the period jitter (p50/p99 ms) of a 77 ms loop on a real-time event loop, idle and with BLE
  at 200 adverts/s (20 beacons at 10 Hz) and the HX711 at 80 SPS running.

    .venv/bin/python bench/bench_ble_hx711.py [--seconds 10] [--hx711-only | --pipeline-only]
                                              [--repeat 3]
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import logging
import random
import statistics
import time
from collections.abc import AsyncIterator, Callable

import structlog

from behaviours.beacons.arrival import Arrival
from behaviours.beacons.tracker import BeaconConfig, BeaconTracker
from behaviours.profiles.laundry.load_check import LoadCheck
from drivers.ble_scanner import BleBeaconScanner, build_ibeacon, parse_ibeacon
from drivers.hx711 import Gain, Hx711, clock_out
from hal.telemetry import NullTelemetry
from sim import vclock
from sim.devices.ble_model import SimBleAir
from sim.devices.hx711_model import SimHx711Lines
from sim.world.body import DiffDriveBody
from sim.world.floor_plan import World
from sim.world.geometry import Pose

UUID = "fda50693-a4e2-4fb1-afcf-c6eb07647825"


def _pct(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))]


def _time_us(fn: Callable[[], object], n: int) -> list[float]:
    out = []
    for _ in range(n):
        t0 = time.perf_counter_ns()
        fn()
        out.append((time.perf_counter_ns() - t0) / 1000)
    return out


def _world(beacons: int) -> World:
    return World.from_table({"width_m": 30, "height_m": 10, "beacons": [
        {"mac": f"C3:00:00:00:00:{i:02X}", "uuid": UUID, "major": 1, "minor": i,
         "x_m": 1.0 + i, "y_m": 5.0, "interval_s": 0.1} for i in range(beacons)]})


async def advert_costs(n: int) -> tuple[list[float], list[float]]:
    body = DiffDriveBody(_world(1), Pose(3.0, 5.0, 0.0))
    air = SimBleAir(body, rng=random.Random(1))
    scanner = BleBeaconScanner([UUID], scanner_factory=air.scanner_factory())
    BeaconTracker(scanner)
    await scanner.start()
    beacon = body.world.beacons[0]
    full = _time_us(lambda: air.advertise(beacon), n)
    data = {0x004C: build_ibeacon(UUID, 1, 2, -59)}
    parse = _time_us(lambda: parse_ibeacon(data), n)
    await scanner.close()
    return full, parse


PIPELINE_STAGES = ("air alone", "+ bleak, no-op callback", "+ scanner driver",
                   "+ tracker, 2 Hz live view", "+ arrival 10 Hz")


class _LiveView(NullTelemetry):
    """An enabled ``Telemetry`` whose ``values`` costs what a JSON encoding of them costs."""

    __slots__ = ()

    @property
    def enabled(self) -> bool:
        return True

    def values(self, topic: str, /, **fields: object) -> None:
        json.dumps(fields)


async def pipeline_cpu_s(stages: int, seconds: float = 351.0) -> tuple[float, int]:
    """CPU seconds of two robots' BLE for ``seconds`` of virtual time, with the first
    ``stages`` of PIPELINE_STAGES; and the adverts sent."""
    tasks: list[asyncio.Task[None]] = []
    closers: list[Callable[[], object]] = []
    airs = []
    for robot in range(2):
        world = World.from_table({"width_m": 30, "height_m": 10, "beacons": [
            {"mac": f"C3:00:00:00:00:{i:02X}", "uuid": UUID, "major": 1, "minor": i,
             "x_m": 1.0 + 3 * i, "y_m": 5.0, "interval_s": 0.1} for i in range(5)]})
        air = SimBleAir(DiffDriveBody(world, Pose(4.0 + robot, 5.0, 0.0)),
                        rng=random.Random(f"{robot}:ble"))
        airs.append(air)
        tasks.append(asyncio.create_task(air.run()))
        if stages == 2:
            bare = air.scanner_factory()(lambda device, adv: None)
            await bare.start()
            closers.append(bare.stop)
        if stages < 3:
            continue
        scanner = BleBeaconScanner([UUID], scanner_factory=air.scanner_factory())
        await scanner.start()
        closers.append(scanner.close)
        if stages < 4:
            continue
        tracker = BeaconTracker(scanner)
        tracker.telemetry = _LiveView()
        tracker.apply_config([BeaconConfig(mac="C3:00:00:00:00:01", is_navigation_target=True,
                                           rssi_threshold_dbm=-65.0)])
        tasks.append(asyncio.create_task(tracker.run()))
        if stages >= 5:
            tasks.append(asyncio.create_task(Arrival(tracker).run()))
    t0 = time.process_time()
    await asyncio.sleep(seconds)
    cpu_s = time.process_time() - t0
    for task in tasks:
        task.cancel()
    for close in closers:
        await close()  # type: ignore[misc]
    return cpu_s, sum(air.counts["sent"] for air in airs)


def pipeline_figures(repeat: int) -> None:
    best: dict[int, float] = {}
    sent = 0
    for _ in range(repeat):  # interleaved, best of each: a shared machine is noisy
        for stages in range(1, len(PIPELINE_STAGES) + 1):
            cpu_s, sent = vclock.run(pipeline_cpu_s(stages))
            best[stages] = min(best.get(stages, cpu_s), cpu_s)
    print(f"laundry's BLE pipeline, 2 robots x 5 beacons at 10 Hz, 351 virtual s "
          f"({sent} adverts sent), CPU best of {repeat}:")
    for stages, name in enumerate(PIPELINE_STAGES, start=1):
        print(f"  {name:28s} {best[stages]:.3f} s  {best[stages] / sent * 1e6:5.1f} us/advert")


def hx711_read_costs(n: int) -> list[float]:
    t = [0.0]
    lines = SimHx711Lines(weight_kg=lambda: 4.2, sps=80, clock=lambda: t[0])
    out = []
    for _ in range(n):
        t[0] += 0.0125
        while lines.read_dout():
            t[0] += 0.0005
        t0 = time.perf_counter_ns()
        clock_out(lines, Gain.A128)
        out.append((time.perf_counter_ns() - t0) / 1000)
    return out


def weighing_cpu_s(virtual_s: float = 351.0, robots: int = 2) -> tuple[float, int]:
    """CPU seconds for ``robots`` HX711 drivers (10 SPS, simulated chips) each feeding a
    ``LoadCheck`` for ``virtual_s`` on the virtual-time loop; and the readings checked."""
    async def main() -> int:
        checks = []
        for i in range(robots):
            lines = SimHx711Lines(weight_kg=lambda: 4.2, rng=random.Random(i),
                                  clock=asyncio.get_running_loop().time)  # as the rig has it
            hx = Hx711(lambda lines=lines: lines, tare_offset=-48_213,  # type: ignore[misc]
                       calibration_factor=103_500.0)
            await hx.start()
            check = LoadCheck(hx)
            checks.append((hx, check, asyncio.create_task(check.run())))
        await asyncio.sleep(virtual_s)
        for hx, _, task in checks:
            task.cancel()
            await hx.close()
        return sum(hx.counts["accepted"] for hx, _, _ in checks)

    t0 = time.process_time()
    readings: int = vclock.run(main())
    return time.process_time() - t0, readings


@contextlib.asynccontextmanager
async def sensor_load(beacons: int = 20, sps: int = 80) -> AsyncIterator[dict[str, int]]:
    """The real BLE scanner driver and beacon tracker fed by ``beacons`` simulated beacons
    advertising at 10 Hz (20: 200 adverts/s), and the real HX711 driver reading the simulated
    chip at ``sps`` - all on the running loop, as the daemon runs them. Yields counters."""
    body = DiffDriveBody(_world(beacons), Pose(10.0, 5.0, 0.0))
    air = SimBleAir(body, rng=random.Random(2))
    scanner = BleBeaconScanner([UUID], scanner_factory=air.scanner_factory())
    BeaconTracker(scanner)
    await scanner.start()
    air_task = asyncio.create_task(air.run())
    lines = SimHx711Lines(weight_kg=lambda: 4.2, sps=sps)
    hx = Hx711(lambda: lines, sps=sps)
    await hx.start()
    counts: dict[str, int] = {}
    try:
        yield counts
    finally:
        air_task.cancel()
        await hx.close()
        await scanner.close()
        counts["adverts"] = air.counts["delivered"]
        counts["hx711_reads"] = lines.reads_completed


async def loop_jitter(seconds: float, loaded: bool) -> list[float]:
    period_s = 1 / 13
    async with contextlib.AsyncExitStack() as stack:
        if loaded:
            await stack.enter_async_context(sensor_load())
        loop = asyncio.get_running_loop()
        errors_ms = []
        next_t = loop.time() + period_s
        end = loop.time() + seconds
        while loop.time() < end:
            await asyncio.sleep(max(0.0, next_t - loop.time()))
            errors_ms.append((loop.time() - next_t) * 1000)
            next_t += period_s
    return errors_ms


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--hx711-only", action="store_true",
                        help="only the HX711 figures (per read, and the laundry weighing)")
    parser.add_argument("--pipeline-only", action="store_true",
                        help="only the simulator's BLE pipeline figures")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    structlog.configure(wrapper_class=structlog.make_filtering_bound_logger(logging.WARNING))
    if args.pipeline_only:
        pipeline_figures(args.repeat)
        return
    reads = hx711_read_costs(5000)
    print(f"HX711 read (25 pulses, sim lines): p50 {_pct(reads, .5):.1f} us, "
          f"p99 {_pct(reads, .99):.1f} us")
    runs = [weighing_cpu_s() for _ in range(3)]
    print(f"2 x HX711 10 SPS + LoadCheck, 351 virtual s: CPU {min(c for c, _ in runs):.3f} s "
          f"best of 3 ({runs[0][1]} readings)")
    if args.hx711_only:
        return

    pipeline_figures(args.repeat)

    full, parse = asyncio.run(advert_costs(20000))
    print(f"advert -> bleak callback -> parse -> tracker: p50 {_pct(full, .5):.1f} us, "
          f"p99 {_pct(full, .99):.1f} us (parse alone p50 {_pct(parse, .5):.1f} us, "
          f"ratio {_pct(full, .5) / _pct(parse, .5):.1f}x)")
    for loaded in (False, True):
        errors = asyncio.run(loop_jitter(args.seconds, loaded))
        what = "BLE 200/s + HX711 80 SPS" if loaded else "idle"
        print(f"13 FPS loop lateness, {what}: p50 {statistics.median(errors):.3f} ms, "
              f"p99 {_pct(errors, .99):.3f} ms, max {max(errors):.3f} ms "
              f"({len(errors)} periods)")


if __name__ == "__main__":
    main()
