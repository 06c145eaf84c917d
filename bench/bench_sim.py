"""Simulator speed: virtual seconds per wall/CPU second on a scenario, and peak memory.

    .venv/bin/python bench/bench_sim.py [SCENARIO] [--runs N] [--turns] [--profile FILE]

Prints, per run, the virtual time simulated and the wall and CPU time the run itself took
(imports and start-up excluded, reported separately), the speed factor (virtual / wall and
virtual / CPU; target >= 200x on square), and the process's peak RSS. Compare CPU figures: the
machine is shared, wall time follows its load.

``--turns`` also prints the event loop's turns and callbacks per virtual second by origin (task
coroutine or callback): in virtual time every wake-up costs a loop turn, so this says which
part of the simulation the loop works for. ``--profile FILE`` runs under cProfile, writes the
stats to FILE and prints the top functions (coroutine resumptions count as calls; figures are
inflated ~2x). For a sampling profile: ``.venv/bin/py-spy record -o out.svg -- .venv/bin/python
bench/bench_sim.py laundry --runs 1``.
"""

from __future__ import annotations

import argparse
import asyncio
import collections
import cProfile
import gc
import importlib
import pstats
import resource
import statistics
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("scenario", nargs="?", default="square")
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--turns", action="store_true",
                        help="count loop turns and callbacks per virtual second")
    parser.add_argument("--profile", metavar="FILE", help="cProfile the runs into FILE")
    opts = parser.parse_args()

    t0_wall, t0_cpu = time.perf_counter(), time.process_time()
    from robotd.profiles import PROFILES
    from robotd.sim import runner as sim_runner
    from robotd.sim.actors import actors_factory
    from robotd.sim.console import SimConsole
    from robotd.sim.scenario import load_scenario

    scenario = load_scenario(opts.scenario)
    # What the runner loads lazily on its first run (the daemon with its state machine and
    # control server, the profile, the fleet's modules): imports, not part of any run.
    importlib.import_module("robotd.daemon")
    if "fleet" in scenario.raw:
        actors_factory(PROFILES.get(scenario.profile))
    PROFILES.build(scenario.profile)

    import_wall = time.perf_counter() - t0_wall
    import_cpu = time.process_time() - t0_cpu
    print(f"imports: wall {import_wall * 1000:.0f} ms, cpu {import_cpu * 1000:.0f} ms")

    from hal.sim import vclock

    profiler = cProfile.Profile() if opts.profile else None
    wall_factors, cpu_factors = [], []
    for i in range(opts.runs):
        args = argparse.Namespace(scenario=opts.scenario, seed=i + 1, realtime=False, speed=None,
                                  report=None, quiet=True, socket=None, config=None, mcu="fake")
        console = SimConsole(quiet=True)
        gc.collect()  # the previous run's garbage is not this run's work
        w0, c0 = time.perf_counter(), time.process_time()
        with tempfile.TemporaryDirectory(prefix="bench-sim-") as workdir, \
                _counting(opts.turns) as counts:
            main = sim_runner._run(args, scenario, console, Path(workdir))
            result = profiler.runcall(vclock.run, main) if profiler else vclock.run(main)
        wall, cpu = time.perf_counter() - w0, time.process_time() - c0
        if isinstance(result, int):
            print(f"run {i + 1}: could not run (exit {result})")
            return 1
        wall_factors.append(result.sim_s / wall)
        cpu_factors.append(result.sim_s / cpu)
        print(f"run {i + 1}: {'ok' if result.ok else 'FAILED'}  virtual {result.sim_s:.1f} s  "
              f"wall {wall:.3f} s  cpu {cpu:.3f} s  speed x{result.sim_s / wall:.0f} (wall) "
              f"x{result.sim_s / cpu:.0f} (cpu)")
        if opts.turns:
            for origin, n in counts.most_common(16):
                print(f"    {n / result.sim_s:8.1f}/s  {origin}")
    rss_mib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"speed factor median: x{statistics.median(wall_factors):.0f} wall, "
          f"x{statistics.median(cpu_factors):.0f} cpu (target >= 200x)")
    print(f"peak RSS: {rss_mib:.0f} MiB")
    if profiler is not None:
        profiler.dump_stats(opts.profile)
        pstats.Stats(opts.profile).sort_stats("tottime").print_stats(25)
    return 0


@contextmanager
def _counting(enabled: bool) -> Iterator[collections.Counter[str]]:
    """Count loop turns and the callbacks run, by the task coroutine or callback behind them."""
    counts: collections.Counter[str] = collections.Counter()
    if not enabled:
        yield counts
        return
    from hal.sim import vclock

    handle_run = asyncio.events.Handle._run
    run_once: Callable[[Any], None] = vclock.VirtualTimeLoop._run_once

    def counted_run(handle: asyncio.Handle) -> None:
        callback = handle._callback  # type: ignore[attr-defined]
        task = getattr(callback, "__self__", None)
        if isinstance(task, asyncio.Task):
            counts["task " + task.get_coro().__qualname__] += 1  # type: ignore[union-attr]
        else:
            counts[getattr(callback, "__qualname__", type(callback).__name__)] += 1
        handle_run(handle)

    def counted_turn(loop: Any) -> None:
        counts["(loop turns)"] += 1
        run_once(loop)

    asyncio.events.Handle._run = counted_run  # type: ignore[method-assign, assignment]
    vclock.VirtualTimeLoop._run_once = counted_turn  # type: ignore[method-assign, assignment]
    vclock.VirtualTimeLoop.inline_callbacks = False
    try:
        yield counts
    finally:
        asyncio.events.Handle._run = handle_run  # type: ignore[method-assign]
        vclock.VirtualTimeLoop._run_once = run_once  # type: ignore[method-assign, assignment]
        vclock.VirtualTimeLoop.inline_callbacks = True


if __name__ == "__main__":
    sys.exit(main())
