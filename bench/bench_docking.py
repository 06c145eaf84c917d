"""Docking from random start poses in a furnished room: success rate, time to dock, final error.

    .venv/bin/python bench/bench_docking.py [--poses 50] [--seed 1] [--first N] [--verbose]

Each trial is a whole simulation (the vacuum profile, the real dock IR driver on the simulated
receivers, the fake motor board): the robot starts at a random pose (any heading; at least
0.8 m from the dock and from walls and furniture; some behind the sofa from the dock, some
facing away), its battery reads 10 %, and the first battery check sends it to the dock. A
trial succeeds when the robot is charging within the time limit. Time to dock is from the
``go_dock`` transition to the successful ``dock.result``, in virtual seconds. The final error
is the robot's pose against the docked pose: sideways off the dock's axis and heading.
Also: the ``docking`` scenario's speed factor (virtual / CPU seconds).
"""

from __future__ import annotations

import argparse
import itertools
import math
import random
import statistics
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from sim import vclock
from sim.runner import SimConsole, _run
from sim.scenario import load_scenario

ROOM_W_M, ROOM_H_M = 5.0, 4.0
DOCK = (0.14, 2.0)
FURNITURE = [  # (x_min, y_min, x_max, y_max): a sofa and an armchair either side of the
    # dock's beams, a table, a low cabinet along the top wall
    (1.0, 2.5, 1.4, 3.2),
    (1.0, 0.8, 1.4, 1.5),
    (3.4, 1.6, 4.0, 2.2),
    (2.6, 3.7, 4.2, 4.0),
]
CLEARANCE_M = 0.8
TIME_LIMIT_S = 400.0

HEADER = """
[scenario]
name = "bench-docking"
profile = "vacuum"

[config.robot]
profile = "vacuum"

[config.vacuum]
battery_check_s = 1.0
standby_s = 3600.0

[config.docking]
ir_combined = ["force_field", "front_left", "front_right"]
charge_full_pct = 100.0

[config.docking.ir_codes]
force_field = 161
front_left = 168
front_right = 164
far_left = 184
far_right = 180
centre = 176

[world]
width_m = {w}
height_m = {h}
dock = {{ x_m = {dx}, y_m = {dy}, heading_deg = 0 }}
walls = [
{walls}
]

[robot]
name = "vac-bench"
x_m = {x:.3f}
y_m = {y:.3f}
heading_deg = {heading:.1f}
body = {{ cleans = true }}

[[script]]
at_s = 0.2
action = "battery.set"
pct = 10

[success]
time_limit_s = {limit}
states_reached = ["docking.dock"]
final_state = "docking.charging"
no_collisions = false
"""


def _box_walls(box: tuple[float, float, float, float]) -> list[str]:
    x0, y0, x1, y1 = box
    corners = [(x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0)]
    return [f"    {{ x1 = {a[0]}, y1 = {a[1]}, x2 = {b[0]}, y2 = {b[1]} }},"
            for a, b in itertools.pairwise(corners)]


def _clear(x: float, y: float) -> bool:
    if min(x, y, ROOM_W_M - x, ROOM_H_M - y) < CLEARANCE_M:
        return False
    if math.hypot(x - DOCK[0], y - DOCK[1]) < CLEARANCE_M:
        return False
    for x0, y0, x1, y1 in FURNITURE:
        dx = max(x0 - x, 0.0, x - x1)
        dy = max(y0 - y, 0.0, y - y1)
        if math.hypot(dx, dy) < CLEARANCE_M:
            return False
    return True


def _crosses_box(x0: float, y0: float, x1: float, y1: float,
                 box: tuple[float, float, float, float]) -> bool:
    """Whether the segment passes through the box (sampled every centimetre)."""
    steps = max(1, int(math.hypot(x1 - x0, y1 - y0) * 100))
    bx0, by0, bx1, by1 = box
    return any(bx0 <= x0 + (x1 - x0) * i / steps <= bx1
               and by0 <= y0 + (y1 - y0) * i / steps <= by1 for i in range(steps + 1))


def describe(poses: list[tuple[float, float, float]]) -> tuple[int, int]:
    """(poses with furniture on the straight line to the dock, poses facing away from it)."""
    blocked = sum(1 for x, y, _ in poses
                  if any(_crosses_box(x, y, *DOCK, box) for box in FURNITURE))
    away = 0
    for x, y, heading in poses:
        bearing = math.degrees(math.atan2(DOCK[1] - y, DOCK[0] - x))
        if abs((heading - bearing + 180) % 360 - 180) > 90:
            away += 1
    return blocked, away


def start_poses(count: int, seed: int) -> list[tuple[float, float, float]]:
    rng = random.Random(seed)
    poses: list[tuple[float, float, float]] = []
    while len(poses) < count:
        x, y = rng.uniform(0, ROOM_W_M), rng.uniform(0, ROOM_H_M)
        if _clear(x, y):
            poses.append((x, y, rng.uniform(-180, 180)))
    return poses


@dataclass
class Trial:
    pose: tuple[float, float, float]
    ok: bool
    time_s: float | None
    lateral_cm: float | None
    heading_deg: float | None
    failures: int
    cpu_s: float
    sim_s: float
    reasons: list[str]
    phases_s: dict[str, float]


def run_trial(pose: tuple[float, float, float], seed: int, workdir: Path) -> Trial:
    x, y, heading = pose
    walls = [w for box in FURNITURE for w in _box_walls(box)]
    text = HEADER.format(w=ROOM_W_M, h=ROOM_H_M, dx=DOCK[0], dy=DOCK[1], walls="\n".join(walls),
                         x=x, y=y, heading=heading, limit=TIME_LIMIT_S)
    path = workdir / "trial.toml"
    path.write_text(text)
    scenario = load_scenario(str(path))
    args = argparse.Namespace(scenario=str(path), seed=seed, realtime=False, speed=None,
                              socket=None, report=None, quiet=True, config=None, mcu="fake")
    cpu0 = time.process_time()
    result: Any = vclock.run(_run(args, scenario, SimConsole(quiet=True), workdir))
    cpu_s = time.process_time() - cpu0
    events = result.events
    start = next((e["t"] for e in events if e.get("kind") == "transition"
                  and e.get("trigger") == "go_dock"), None)
    done = next((e for e in events if e.get("kind") == "dock.result" and e.get("success")),
                None)
    failures = sum(1 for e in events if e.get("kind") == "dock.result"
                   and not e.get("success"))
    fig = next(iter(result.figures.values()), {})
    ok = bool(result.ok)
    end_s = done["t"] if done is not None else result.sim_s
    return Trial(pose, ok, None if done is None or start is None else done["t"] - start,
                 fig.get("dock_lateral_cm") if ok else None,
                 fig.get("dock_heading_deg") if ok else None, failures, cpu_s,
                 result.sim_s, list(result.reasons), phase_times(events, end_s))


def phase_times(events: list[dict[str, Any]], end_s: float) -> dict[str, float]:
    """Virtual seconds spent in each docking phase (``docking.<phase>``) up to ``end_s``."""
    spent: dict[str, float] = {}
    phase, since = "", 0.0
    for event in events:
        if event.get("kind") != "transition" or event["t"] > end_s:
            continue
        if phase:
            spent[phase] = spent.get(phase, 0.0) + event["t"] - since
        dst = str(event.get("dst", ""))
        parts = dst.split(".")
        phase = parts[1] if parts[0] == "docking" and len(parts) > 1 else ""
        since = event["t"]
    if phase:
        spent[phase] = spent.get(phase, 0.0) + end_s - since
    return spent


def speed_factor(scenario: str = "docking") -> tuple[float, float]:
    """(virtual s, virtual / CPU s) of a built-in scenario."""
    with tempfile.TemporaryDirectory(prefix="bench-docking-") as tmp:
        loaded = load_scenario(scenario)
        args = argparse.Namespace(scenario=scenario, seed=1, realtime=False, speed=None,
                                  socket=None, report=None, quiet=True, config=None, mcu="fake")
        cpu0 = time.process_time()
        result: Any = vclock.run(_run(args, loaded, SimConsole(quiet=True), Path(tmp)))
        cpu_s = time.process_time() - cpu0
    return result.sim_s, result.sim_s / cpu_s


def _pct(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, math.ceil(q * len(ordered)) - 1)]


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--poses", type=int, default=50)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--first", type=int, default=0, help="skip the first N poses")
    parser.add_argument("--verbose", action="store_true")
    parser.add_argument("--no-speed", action="store_true")
    opts = parser.parse_args()
    trials: list[Trial] = []
    poses = start_poses(opts.poses, opts.seed)[opts.first:]
    with tempfile.TemporaryDirectory(prefix="bench-docking-") as tmp:
        for i, pose in enumerate(poses, start=opts.first):
            workdir = Path(tmp) / f"trial-{i}"  # a fresh state store: no latch carried over
            workdir.mkdir()
            trial = run_trial(pose, opts.seed * 100 + i, workdir)
            trials.append(trial)
            if opts.verbose or not trial.ok:
                print(f"  #{i} start ({pose[0]:.2f}, {pose[1]:.2f}, {pose[2]:.0f} deg): "
                      f"{'ok' if trial.ok else 'FAILED'} time {trial.time_s} s, lateral "
                      f"{trial.lateral_cm} cm, heading {trial.heading_deg} deg, "
                      f"{trial.failures} failed attempt(s), cpu {trial.cpu_s:.1f} s; "
                      + ", ".join(f"{k} {v:.1f}" for k, v in trial.phases_s.items())
                      + ("" if trial.ok else f": {'; '.join(trial.reasons)[:200]}"),
                      flush=True)
    ok = [t for t in trials if t.ok and t.time_s is not None]
    blocked, away = describe([t.pose for t in trials])
    print(f"docking from {len(trials)} random start poses (seed {opts.seed}; {away} facing "
          f"away from the dock, {blocked} with furniture on the line to it):")
    print(f"  success {len(ok)}/{len(trials)} = {100 * len(ok) / max(1, len(trials)):.1f} %")
    if ok:
        times = [t.time_s for t in ok if t.time_s is not None]
        lateral = [abs(t.lateral_cm or 0.0) for t in ok]
        heading = [abs(t.heading_deg or 0.0) for t in ok]
        print(f"  time to dock (virtual): median {statistics.median(times):.1f} s, "
              f"p95 {_pct(times, 0.95):.1f} s, max {max(times):.1f} s")
        print(f"  final lateral error: median {statistics.median(lateral):.2f} cm, "
              f"p95 {_pct(lateral, 0.95):.2f} cm, max {max(lateral):.2f} cm")
        print(f"  final heading error: median {statistics.median(heading):.2f} deg, "
              f"p95 {_pct(heading, 0.95):.2f} deg, max {max(heading):.2f} deg")
        print(f"  trials with a failed attempt first: {sum(1 for t in ok if t.failures)}")
        phases = sorted({k for t in ok for k in t.phases_s})
        print("  median time per phase: " + ", ".join(
            f"{k} {statistics.median([t.phases_s.get(k, 0.0) for t in ok]):.1f} s"
            for k in phases))
    cpu = sum(t.cpu_s for t in trials)
    sim = sum(t.sim_s for t in trials)
    print(f"  simulated {sim:.0f} s in {cpu:.0f} s CPU (x{sim / max(cpu, 1e-9):.0f})")
    if not opts.no_speed:
        sim_s, factor = speed_factor()
        print(f"  scenario docking: {sim_s:.0f} s virtual, speed factor x{factor:.0f} (CPU)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
