"""The line-following loop's latency and period jitter at 13 FPS, on a real (wall-clock) loop.

    .venv/bin/python bench/bench_line_loop.py [--seconds S]

The control loop, fed by a 30 FPS camera replaying rendered frames, once alone and once with
the real BLE scanner driver and beacon tracker taking 200 adverts/s from 20 simulated beacons
and the real HX711 driver bit-banging the simulated chip at 80 SPS on the same loop
(bench_ble_hx711.sensor_load); each under default scheduling and as systemd/robotd.service
schedules the daemon (in a child process that has it from its start). Prints frame-to-MOTOR
latency, tick period jitter (p50/p99) and the hypervisor's steal time during each run, which
on a VM sets the jitter's tail. Target jitter p99 <= 2 ms.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import itertools
import os
import re
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from bench_ble_hx711 import sensor_load  # bench/ is on sys.path when run as a script
from bench_line_tracker import pct, render_frames

from behaviours.line.follow import LineFollower
from hal.looptime.deadline import DeadlineSleeper
from hal.readings import Frame, LinkStats, MotorCommand
from robotd.config.loader import defaults
from robotd.config.settings import Settings
from sim.devices.camera_model import CameraMount


class ReplayCamera:
    """Pre-rendered frames delivered at a camera's rate (rendering cost kept off the loop)."""

    name = "camera"

    def __init__(self, images: list[Any], fps: float) -> None:
        self.images = images
        self.fps = fps
        self.width_px = images[0].shape[1]
        self.height_px = images[0].shape[0]
        self._frame: Frame | None = None
        self._waiters: list[asyncio.Future[Frame]] = []
        self._task: asyncio.Task[None] | None = None

    async def start(self) -> None:
        self._task = asyncio.create_task(self._run())

    async def close(self) -> None:
        if self._task:
            self._task.cancel()

    def status(self) -> dict[str, Any]:
        return {}

    def latest(self) -> Frame | None:
        return self._frame

    async def next_reading(self) -> Frame:
        fut: asyncio.Future[Frame] = asyncio.get_running_loop().create_future()
        self._waiters.append(fut)
        return await fut

    async def _run(self) -> None:
        loop = asyncio.get_running_loop()
        deadline = loop.time()
        seq = 0
        while True:
            seq += 1
            self._frame = Frame(self.images[seq % len(self.images)], seq, loop.time())
            waiters, self._waiters = self._waiters, []
            for fut in waiters:
                if not fut.done():
                    fut.set_result(self._frame)
            deadline += 1 / self.fps
            await asyncio.sleep(max(0.0, deadline - loop.time()))


class TimedMotors:
    name = "motors"
    connected = True

    def __init__(self) -> None:
        self.sent: list[float] = []

    async def start(self) -> None:
        return None

    async def close(self) -> None:
        return None

    async def drive(self, command: MotorCommand) -> None:
        self.sent.append(asyncio.get_running_loop().time())
        del command

    async def stop(self) -> None:
        return None

    def on_link_change(self, callback: Callable[[bool], None]) -> None:
        return None

    def link_stats(self) -> LinkStats:
        return LinkStats(connected=True)

    def status(self) -> dict[str, Any]:
        return {}


async def control_run(images: list[Any], seconds: float, loaded: bool) -> dict[str, Any]:
    camera = ReplayCamera(images, fps=30.0)
    motors = TimedMotors()
    follower = LineFollower(camera, motors, Settings(defaults()))
    await camera.start()
    counts: dict[str, int] = {}
    async with contextlib.AsyncExitStack() as stack:
        if loaded:
            counts = await stack.enter_async_context(sensor_load(beacons=20, sps=80))
        await asyncio.sleep(0.2)
        task = asyncio.create_task(follower.run())
        await asyncio.sleep(seconds)
        task.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await task
    await camera.close()
    probe = DeadlineSleeper(asyncio.get_running_loop())  # what the follower's sleeper used
    precise = probe.precise
    probe.close()
    ticks = follower.recent_ticks()
    period = follower.period_s
    jitter = [abs(b - a - period) for a, b in itertools.pairwise(ticks)]
    latencies = follower.recent_latencies_s()
    processing = [m - t for t, m in zip(ticks[-len(motors.sent):], motors.sent, strict=False)]
    return {"ticks": len(ticks), "jitter": jitter, "latency": latencies,
            "processing": processing, "overruns": follower.overruns, "load": counts,
            "late_p99_ms": follower.status()["late_p99_ms"],
            "precise": precise}


UNIT = Path(__file__).resolve().parent.parent / "systemd" / "robotd.service"
POLICIES = {"rr": os.SCHED_RR, "fifo": os.SCHED_FIFO, "other": os.SCHED_OTHER}
POLICY_NAMES = {v: f"SCHED_{k.upper()}" for k, v in POLICIES.items()}


def unit_scheduling() -> tuple[int, int, int] | None:
    """(nice, policy, priority) that systemd/robotd.service gives the daemon; None when it
    sets none of them."""
    text = UNIT.read_text()

    def setting(name: str) -> str | None:
        found = re.search(rf"^{name}=(\S+)", text, re.MULTILINE)
        return found.group(1) if found else None

    nice, policy, priority = (setting("Nice"), setting("CPUSchedulingPolicy"),
                              setting("CPUSchedulingPriority"))
    if nice is None and policy is None:
        return None
    return (int(nice or 0), POLICIES.get(policy or "other", os.SCHED_OTHER),
            int(priority or 0))


def bench_loop(seconds: float) -> None:
    """Each scheduling in a child process that has it from its start, as systemd gives it to
    the service: every thread inherits it (OpenCV's worker threads too)."""
    service = unit_scheduling()
    for sched in ("default", "service") if service is not None else ("default",):
        def set_policy(sched: str = sched) -> None:
            if sched == "service" and service is not None:
                nice, policy, priority = service
                os.setpriority(os.PRIO_PROCESS, 0, nice)
                os.sched_setscheduler(0, policy, os.sched_param(priority))
        try:  # the scheduling is set in the child before it starts any thread
            subprocess.run([sys.executable, __file__, "--child", sched, "--seconds", str(seconds)],
                           check=True, preexec_fn=set_policy)
        except subprocess.CalledProcessError as exc:
            if sched == "service":
                print(f"\nscheduled as robotd.service runs it: could not be set here ({exc}; "
                      "needs root or CAP_SYS_NICE)")
            else:
                raise


def loop_child(seconds: float, sched: str) -> None:
    mount = CameraMount()
    images = [f for f, _ in render_frames(mount, 60, seed=99)]
    policy = os.sched_getscheduler(0)
    label = (f"default scheduling ({POLICY_NAMES.get(policy, policy)}, nice "
             f"{os.getpriority(os.PRIO_PROCESS, 0)})")
    if sched == "service":
        label = f"scheduled as {UNIT.name} runs it: " + label.split("(", 1)[1].rstrip(")")
        if policy != os.SCHED_OTHER:
            label += f", priority {os.sched_getparam(0).sched_priority}"
    for loaded in (False, True):
        print_loop_run(label, images, seconds, loaded)


def cpu_jiffies() -> tuple[int, int]:
    """(steal, total) CPU time of the whole machine so far, in jiffies (Linux /proc/stat):
    steal is time this VM's vCPUs were ready to run but the host ran something else."""
    try:
        fields = [int(v) for v in Path("/proc/stat").read_text().split("\n", 1)[0].split()[1:]]
    except (OSError, ValueError):
        return 0, 0
    return (fields[7] if len(fields) > 7 else 0), sum(fields[:8])


def print_loop_run(sched_label: str, images: list[Any], seconds: float, loaded: bool) -> None:
    steal0, total0 = cpu_jiffies()
    r = asyncio.run(control_run(images, seconds, loaded))
    steal1, total1 = cpu_jiffies()
    steal_pct = 100 * (steal1 - steal0) / max(1, total1 - total0)
    over_2ms = sum(j > 0.002 for j in r["jitter"])
    label = "with BLE 200/s + HX711 80/s" if loaded else "alone"
    rates = (f" (real drivers on simulated radio and chip: "
             f"{r['load']['adverts'] / seconds:.0f} adverts/s, "
             f"{r['load']['hx711_reads'] / seconds:.0f} HX711 reads/s)") if loaded else ""
    print(f"\ncontrol loop at 13 FPS, {seconds:.0f} s wall clock, {label}{rates}")
    print(f"  {sched_label}; precise ticks (timerfd): {r['precise']}")
    print(f"  ticks {r['ticks']}, overruns {r['overruns']}")
    print(f"  period jitter |dt - 76.9 ms|: p50 {pct(r['jitter'], 50) * 1e3:.3f} ms  "
          f"p99 {pct(r['jitter'], 99) * 1e3:.3f} ms  max {max(r['jitter']) * 1e3:.3f} ms  "
          f"({over_2ms} of {len(r['jitter'])} periods over 2 ms)")
    print(f"  hypervisor steal during the run: {steal_pct:.1f} % of the machine's CPU time "
          f"(load average {os.getloadavg()[0]:.2f})")
    print(f"  tick start after its deadline: p99 {r['late_p99_ms']:.3f} ms")
    print(f"  frame-to-MOTOR latency (incl. frame age, camera 30 FPS): "
          f"p50 {pct(r['latency'], 50) * 1e3:.2f} ms  p99 {pct(r['latency'], 99) * 1e3:.2f} ms")
    print(f"  tick-to-MOTOR (tracker + control): p50 {pct(r['processing'], 50) * 1e3:.3f} ms"
          f"  p99 {pct(r['processing'], 99) * 1e3:.3f} ms")


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--seconds", type=float, default=30.0)
    parser.add_argument("--child", choices=("default", "service"), help=argparse.SUPPRESS)
    opts = parser.parse_args()
    if opts.child:
        loop_child(opts.seconds, opts.child)
        return 0
    print(f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs (shared machine)")
    sys.stdout.flush()
    bench_loop(opts.seconds)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
