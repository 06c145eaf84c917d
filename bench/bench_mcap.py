"""What recording run.mcap costs the simulator: the same scenario with and without, one process.

    .venv/bin/python bench/bench_mcap.py [SCENARIO] [--runs N] [--seed S]

Runs the scenario N times without recording and N times recording ``run.mcap`` (what
``robotd sim --report DIR`` adds), alternating so both see the same machine load, and prints
each run's virtual time, wall and CPU time, the recording's size, and the median CPU ratio
(recording / not; the requirement is <= 1.10 on ``laundry``) and the ratio of the best run of
each (the least disturbed by other work), and the CPU time spent inside the live view's
publish calls (timed around each outermost call: the figure least disturbed by the machine's
load). Compare CPU figures: the machine is shared, wall time follows its load. The report's
other files (events.jsonl, trajectory.png) are not written in either case: only the recording
differs.
"""

from __future__ import annotations

import argparse
import functools
import gc
import statistics
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

_INSIDE = [0.0, 0]  # main-thread CPU seconds in the live view's calls; the nesting depth


def _timed(fn: Callable[..., Any]) -> Callable[..., Any]:
    """``fn`` adding the main thread's CPU time of its outermost calls to ``_INSIDE``."""

    @functools.wraps(fn)
    def timed(*args: Any, **kwargs: Any) -> Any:
        if _INSIDE[1]:
            return fn(*args, **kwargs)
        _INSIDE[1] = 1
        t0 = time.thread_time()
        try:
            return fn(*args, **kwargs)
        finally:
            _INSIDE[0] += time.thread_time() - t0
            _INSIDE[1] = 0

    return timed


def _instrument() -> None:
    """Time the adapter's publish calls from the robot's side: a figure less disturbed by the
    machine's load than a run's total (the callers' own few lines are not in it)."""
    from robotd.viz.telemetry import FoxgloveTelemetry

    for method in ("pose", "poses", "scan", "path", "grid", "graph", "image", "values",
                   "sample", "flush"):  # flush: the JSON values a recording alone holds
        setattr(FoxgloveTelemetry, method, _timed(getattr(FoxgloveTelemetry, method)))


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("scenario", nargs="?", default="laundry")
    parser.add_argument("--runs", type=int, default=2)
    parser.add_argument("--seed", type=int, default=21)
    opts = parser.parse_args()

    import importlib

    from robotd.profiles import PROFILES
    from sim import runner as sim_runner
    from sim import vclock
    from sim.console import SimConsole
    from sim.scenario import load_scenario

    scenario = load_scenario(opts.scenario)
    importlib.import_module("robotd.daemon")
    PROFILES.build(scenario.profile)
    _instrument()

    cpu: dict[bool, list[float]] = {False: [], True: []}
    inside: list[float] = []
    for i in range(opts.runs):
        for record in (False, True):
            with tempfile.TemporaryDirectory(prefix="bench-mcap-") as tmp:
                report = Path(tmp) / "report"
                report.mkdir()
                args = argparse.Namespace(
                    scenario=opts.scenario, seed=opts.seed, realtime=False, speed=None,
                    report=str(report) if record else None, quiet=True, socket=None,
                    config=None, mcu="fake", viz=False)
                gc.collect()
                _INSIDE[0] = 0.0
                w0, c0 = time.perf_counter(), time.process_time()
                workdir = Path(tmp) / "work"
                workdir.mkdir()
                result = vclock.run(sim_runner._run(args, scenario, SimConsole(quiet=True),
                                                    workdir))
                wall, used = time.perf_counter() - w0, time.process_time() - c0
                if isinstance(result, int):
                    print(f"run {i + 1}: could not run (exit {result})")
                    return 1
                mcap = report / "run.mcap"
                size = f"{mcap.stat().st_size / 1e6:.1f} MB" if mcap.exists() else "-"
                cpu[record].append(used)
                if record:
                    inside.append(float(_INSIDE[0]))
                print(f"run {i + 1} {'recording' if record else 'plain    '}: "
                      f"{'ok' if result.ok else 'FAILED'}  virtual {result.sim_s:.1f} s  "
                      f"wall {wall:.2f} s  cpu {used:.2f} s  x{result.sim_s / used:.0f} (cpu)"
                      f"  run.mcap {size}")
    ratio = statistics.median(cpu[True]) / statistics.median(cpu[False])
    best = min(cpu[True]) / min(cpu[False])  # the least disturbed run of each
    print(f"recording overhead on {opts.scenario}: cpu x{ratio:.3f} median "
          f"({(ratio - 1) * 100:+.1f} %), x{best:.3f} best of each "
          f"({(best - 1) * 100:+.1f} %); requirement <= +10 %")
    share = statistics.median(inside) / statistics.median(cpu[False])
    print(f"cpu inside the live view's publish calls: median {statistics.median(inside):.2f} s "
          f"per run, {share * 100:.1f} % of a run without recording")
    return 0


if __name__ == "__main__":
    sys.exit(main())
