"""Simulator speed: virtual seconds per wall/CPU second on a scenario, and peak memory.

    .venv/bin/python bench/bench_sim.py [SCENARIO] [--runs N] [--turns] [--profile FILE]
                                        [--no-reference] [--record] [--overhead PAIRS]

Prints, per run, the virtual time simulated and the wall and CPU time the run itself took
(imports and start-up excluded, reported separately), the speed factor (virtual / wall and
virtual / CPU; targets: >= 200x on square, >= 60x on laundry with recording), and the
process's peak RSS. A scenario other than ``square`` is followed by ``square`` in the same
process (unless ``--no-reference`` or ``--profile``), and both medians are printed together:
compare them, and CPU figures rather than wall ones; the machine is shared, wall time follows
its load.

``--record`` runs each scenario as ``robotd sim --report DIR`` does, writing ``DIR/run.mcap``
(the events and the PNG are written after the run and are not timed, as in the summary).

``--overhead PAIRS`` runs the scenario without and with recording in turn, PAIRS times, in
one process (after one recorded run not counted; every other pair recorded first), and prints
the recording's CPU cost per pair, their median and quartiles (the issue's <= 10 %): separate
bench runs drift with the machine by more than that.

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
import contextlib
import cProfile
import gc
import importlib
import io
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
    parser.add_argument("--no-reference", action="store_true",
                        help=f"do not also run {REFERENCE!r} for comparison")
    parser.add_argument("--record", action="store_true",
                        help="record run.mcap as --report does (the issue's figure)")
    parser.add_argument("--overhead", type=int, metavar="PAIRS",
                        help="the recording's cost: PAIRS runs without and with it, in turn")
    opts = parser.parse_args()
    if opts.overhead:
        return _overhead(opts.scenario, opts.overhead)

    names = [opts.scenario]
    if opts.scenario != REFERENCE and not opts.no_reference and not opts.profile:
        names.append(REFERENCE)  # same process, same load: the two factors compare
    t0_wall, t0_cpu = time.perf_counter(), time.process_time()
    for name in names:
        _load(name)
    import_wall = time.perf_counter() - t0_wall
    import_cpu = time.process_time() - t0_cpu
    print(f"imports: wall {import_wall * 1000:.0f} ms, cpu {import_cpu * 1000:.0f} ms")

    profiler = cProfile.Profile() if opts.profile else None
    medians: dict[str, tuple[float, float]] = {}
    for name in names:
        factors = _bench(name, opts.runs, opts.turns, profiler, record=opts.record)
        if factors is None:
            return 1
        medians[name] = factors
    rss_mib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    for name, (wall_x, cpu_x) in medians.items():
        print(f"speed factor median {name:>14}{' recorded' if opts.record else ''}: "
              f"x{wall_x:.0f} wall, x{cpu_x:.0f} cpu "
              f"(target {TARGETS.get(name, '-')})")
    print(f"peak RSS: {rss_mib:.0f} MiB")
    if profiler is not None:
        profiler.dump_stats(opts.profile)
        pstats.Stats(opts.profile).sort_stats("tottime").print_stats(25)
    return 0


def _overhead(name: str, pairs: int) -> int:
    """Runs without and with recording in turn, in one process: the machine's speed drifts
    between separate bench runs by more than the recording costs, so only pairs compare.

    One recorded run first, not counted (the first recording makes its channels and schemas
    once per process); then the pairs in the order plain, recorded, recorded, plain, ... so a
    drift of the machine's speed during the series falls on both sides alike. Plain pairs of
    one process differ by +-6 % on this machine (an A/A check), hence the median of many.
    """
    _load(name)
    with contextlib.redirect_stdout(io.StringIO()):
        _bench(name, 1, False, None, record=True)
    costs = []
    for i in range(pairs):
        order = (False, True) if i % 2 == 0 else (True, False)
        cpu_x: dict[bool, float] = {}
        with contextlib.redirect_stdout(io.StringIO()):
            for record in order:
                factors = _bench(name, 1, False, None, record=record)
                if factors is None:
                    return 1
                cpu_x[record] = factors[1]
        costs.append(cpu_x[False] / cpu_x[True] - 1)
        print(f"pair {i + 1}: x{cpu_x[False]:.1f} cpu without, x{cpu_x[True]:.1f} with "
              f"recording{' (run first)' if order[0] else ''}: {100 * costs[-1]:+.1f} % CPU")
    q1, median, q3 = statistics.quantiles(costs, n=4) if len(costs) > 1 else costs * 3
    print(f"recording's cost, median of {pairs} pairs: {100 * median:+.1f} % CPU "
          f"(quartiles {100 * q1:+.1f} .. {100 * q3:+.1f} %; target <= 10 %)")
    return 0


REFERENCE = "square"
TARGETS = {"square": ">= x200", "laundry": ">= x60 with recording, x70 without"}


def _load(name: str) -> None:
    """Import what the runner loads lazily on its first run of ``name``: not part of a run."""
    from robotd.profiles import PROFILES
    from sim.actors import actors_factory
    from sim.scenario import load_scenario

    scenario = load_scenario(name)
    # The daemon with its state machine and control server, the profile, the fleet's modules.
    importlib.import_module("robotd.daemon")
    if "fleet" in scenario.raw:
        actors_factory(scenario.profile)
    PROFILES.build(scenario.profile)


def _bench(name: str, runs: int, turns: bool,
           profiler: cProfile.Profile | None, *,
           record: bool = False) -> tuple[float, float] | None:
    """Run scenario ``name`` ``runs`` times (seeds 1..runs); median (wall, cpu) speed factors."""
    from sim import runner as sim_runner
    from sim import vclock
    from sim.console import SimConsole
    from sim.scenario import load_scenario

    scenario = load_scenario(name)
    wall_factors, cpu_factors = [], []
    for i in range(runs):
        console = SimConsole(quiet=True)
        gc.collect()  # the previous run's garbage is not this run's work
        w0, c0 = time.perf_counter(), time.process_time()
        with tempfile.TemporaryDirectory(prefix="bench-sim-") as workdir, \
                _counting(turns) as counts:
            report = str(Path(workdir) / "report") if record else None
            if report is not None:
                Path(report).mkdir()
            args = argparse.Namespace(scenario=name, seed=i + 1, realtime=False, speed=None,
                                      report=report, quiet=True, socket=None, config=None,
                                      mcu="fake")
            main = sim_runner._run(args, scenario, console, Path(workdir))
            result = profiler.runcall(vclock.run, main) if profiler else vclock.run(main)
        wall, cpu = time.perf_counter() - w0, time.process_time() - c0
        if isinstance(result, int):
            print(f"{name} run {i + 1}: could not run (exit {result})")
            return None
        wall_factors.append(result.sim_s / wall)
        cpu_factors.append(result.sim_s / cpu)
        print(f"{name} run {i + 1}: {'ok' if result.ok else 'FAILED'}  virtual "
              f"{result.sim_s:.1f} s  wall {wall:.3f} s  cpu {cpu:.3f} s  speed "
              f"x{result.sim_s / wall:.0f} (wall) x{result.sim_s / cpu:.0f} (cpu)")
        if turns:
            for origin, n in counts.most_common(16):
                print(f"    {n / result.sim_s:8.1f}/s  {origin}")
    return statistics.median(wall_factors), statistics.median(cpu_factors)


@contextmanager
def _counting(enabled: bool) -> Iterator[collections.Counter[str]]:
    """Count loop turns and the callbacks run, by the task coroutine or callback behind them."""
    counts: collections.Counter[str] = collections.Counter()
    if not enabled:
        yield counts
        return
    from sim import vclock

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
