"""RelayBot's figures: QR decoding on a forward camera, and what it costs the control loop.

``--part qr`` prints:
- decode time per 640 x 480 frame with OpenCV's ``QRCodeDetector`` (p50/p99 ms), frames with a
  customer's code in view and empty frames apart;
- the share of frames decoded with the customer 0.5-1.0 m ahead (the simulated forward camera:
  code size from the distance, tilt, hand shake, blur, noise), per 0.1 m band;
- the lateness (p50/p99 ms) of a 100 Hz control tick on a real-time event loop: idle, while the
  reader decodes every frame on its worker thread, and (for contrast) with decoding on the loop.

    .venv/bin/python bench/bench_delivery.py --part qr [--frames 200] [--seconds 5]

``--part speed`` prints the whole mission's speed: virtual seconds of ``robotd sim delivery``
(and the other delivery built-ins) per wall second and per CPU second of this process (its
worker threads included: QR decoding, SQLite), median over ``--runs`` seeds, without the report.

    .venv/bin/python bench/bench_delivery.py --part speed [--runs 3] [--scenarios delivery]
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import logging
import math
import random
import time
from collections.abc import AsyncIterator, Callable, Coroutine
from typing import Any

import cv2
import structlog

from drivers.camera.qr_reader import QrCameraReader
from hal.readings import Frame
from sim.devices.qr_camera_model import SimQrCamera
from sim.world.body import DiffDriveBody
from sim.world.floor_plan import Person, World
from sim.world.geometry import Pose

PAYLOAD = '{"order_id": 1042, "secret_key": "Qm7xT2pL9vRk4sWd"}'
CUSTOMER = (3.0, 2.0)


def _pct(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))]


def _camera(seed: int) -> SimQrCamera:
    world = World.from_table({"width_m": 6, "height_m": 4})
    world.people.append(Person("customer", *CUSTOMER, qr_payload=PAYLOAD))
    return SimQrCamera(world, DiffDriveBody(world, Pose(1.0, 2.0, 0.0)), seed=seed)


def _pose_at(distance_m: float, rng: random.Random) -> Pose:
    """The robot ``distance_m`` from the customer, facing them within +-10 degrees."""
    bearing = rng.uniform(-math.pi, math.pi)
    x = CUSTOMER[0] + distance_m * math.cos(bearing)
    y = CUSTOMER[1] + distance_m * math.sin(bearing)
    return Pose(x, y, bearing + math.pi + math.radians(rng.uniform(-10, 10)))


def decode_times(frames: int, seed: int) -> None:
    cam = _camera(seed)
    rng = random.Random(seed)
    detector = cv2.QRCodeDetector()
    for label, dist in (("code in view (0.6 m)", 0.6), ("no code in view", None)):
        times_ms = []
        for _ in range(frames):
            pose = _pose_at(dist, rng) if dist else Pose(1.0, 2.0, math.pi)
            image = cam.render(pose)
            t0 = time.perf_counter()
            detector.detectAndDecodeBytes(image)
            times_ms.append((time.perf_counter() - t0) * 1000)
        print(f"decode 640x480, {label}: p50 {_pct(times_ms, 0.5):.1f} ms, "
              f"p99 {_pct(times_ms, 0.99):.1f} ms ({frames} frames)")


def decode_share(frames: int, seed: int) -> None:
    cam = _camera(seed)
    rng = random.Random(seed + 1)
    detector = cv2.QRCodeDetector()
    total_ok = total = 0
    bands = []
    for band in range(5):
        lo = 0.5 + 0.1 * band
        ok = 0
        for _ in range(frames // 5):
            image = cam.render(_pose_at(rng.uniform(lo, lo + 0.1), rng))
            ok += detector.detectAndDecodeBytes(image)[0] == PAYLOAD.encode()
        bands.append(f"{lo:.1f}-{lo + 0.1:.1f} m {100 * ok / (frames // 5):.0f} %")
        total_ok += ok
        total += frames // 5
    print(f"decoded at 0.5-1.0 m: {100 * total_ok / total:.0f} % of {total} frames "
          f"({', '.join(bands)})")


async def _tick_lateness(seconds: float, period_s: float = 0.01) -> list[float]:
    loop = asyncio.get_running_loop()
    late_ms = []
    deadline = loop.time() + period_s
    end = loop.time() + seconds
    while loop.time() < end:
        await asyncio.sleep(max(0.0, deadline - loop.time()))
        late_ms.append((loop.time() - deadline) * 1000)
        deadline += period_s
    return late_ms


@contextlib.asynccontextmanager
async def _running(work: Callable[[], Coroutine[Any, Any, None]]) -> AsyncIterator[None]:
    task = asyncio.get_running_loop().create_task(work())
    try:
        yield
    finally:
        task.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await task


class _ReplayCamera:
    """Pre-rendered frames at 10 FPS: on the robot capture runs on the camera's own thread, so
    the simulator's rendering must not be counted against the loop here."""

    name = "replay"
    width_px, height_px = 640, 480

    def __init__(self, images: list[Any]) -> None:
        self._images = images
        self._seq = 0

    async def start(self) -> None:
        return None

    async def close(self) -> None:
        return None

    def status(self) -> dict[str, Any]:
        return {}

    def latest(self) -> Frame | None:
        return None

    async def next_reading(self) -> Frame:
        await asyncio.sleep(0.1)
        self._seq += 1
        loop = asyncio.get_running_loop()
        return Frame(self._images[self._seq % len(self._images)], self._seq, loop.time())


async def loop_lag(seconds: float, seed: int) -> None:
    cam = _camera(seed)
    rng = random.Random(seed + 2)
    camera = _ReplayCamera([cam.render(_pose_at(rng.uniform(0.5, 0.8), rng)) for _ in range(20)])
    reader = QrCameraReader(camera)
    await reader.start()
    decoded = 0

    async def decode_in_thread() -> None:
        nonlocal decoded
        while True:
            decoded += bool(await reader.next_code(1.0))

    async def decode_on_loop() -> None:
        detector = cv2.QRCodeDetector()
        while True:
            frame = await camera.next_reading()
            detector.detectAndDecodeBytes(frame.image)

    async def idle() -> None:
        await asyncio.Event().wait()

    try:
        for label, work in (("idle", idle), ("decoding on the worker thread", decode_in_thread),
                            ("decoding on the event loop (contrast)", decode_on_loop)):
            async with _running(work):
                late = await _tick_lateness(seconds)
            print(f"100 Hz tick lateness, {label}: p50 {_pct(late, 0.5):.2f} ms, "
                  f"p99 {_pct(late, 0.99):.2f} ms, max {max(late):.1f} ms")
        print(f"(codes decoded on the thread: {decoded}, frames {reader.frames_decoded})")
    finally:
        await reader.close()


def scenario_speed(name: str, runs: int) -> dict[str, Any]:
    """Virtual s per wall s and per CPU s of ``robotd sim <name>`` (seeds 1..runs)."""
    import gc
    import statistics
    import tempfile
    from pathlib import Path

    from sim import runner as sim_runner
    from sim import vclock
    from sim.console import SimConsole
    from sim.scenario import load_scenario

    wall_x, cpu_x, sim_s, oks = [], [], [], []
    for i in range(runs):
        scenario = load_scenario(name)  # afresh: a run moves the world's people
        args = argparse.Namespace(scenario=name, seed=i + 1, realtime=False, speed=None,
                                  report=None, quiet=True, socket=None, config=None, mcu="fake")
        gc.collect()
        w0, c0 = time.perf_counter(), time.process_time()
        with tempfile.TemporaryDirectory(prefix="bench-delivery-") as workdir:
            result = vclock.run(sim_runner._run(args, scenario, SimConsole(quiet=True),
                                                Path(workdir)))
        wall, cpu = time.perf_counter() - w0, time.process_time() - c0
        if isinstance(result, int):
            return {"scenario": name, "error": f"exit {result}"}
        oks.append(result.ok)
        sim_s.append(result.sim_s)
        wall_x.append(result.sim_s / wall)
        cpu_x.append(result.sim_s / cpu)
    return {"scenario": name, "runs": runs, "ok": all(oks),
            "virtual_s": round(statistics.median(sim_s), 1),
            "speed_wall_x": round(statistics.median(wall_x), 1),
            "speed_cpu_x": round(statistics.median(cpu_x), 1)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--part", choices=["qr", "speed"], default="qr")
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--scenarios", default="delivery",
                        help="comma-separated delivery built-ins for --part speed")
    parser.add_argument("--frames", type=int, default=200)
    parser.add_argument("--seconds", type=float, default=5.0)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    structlog.configure(wrapper_class=structlog.make_filtering_bound_logger(logging.WARNING))
    if args.part == "speed":
        for name in args.scenarios.split(","):
            print(scenario_speed(name.strip(), args.runs))
        return
    decode_times(args.frames, args.seed)
    decode_share(args.frames, args.seed)
    asyncio.run(loop_lag(args.seconds, args.seed))


if __name__ == "__main__":
    main()
