"""Simulator speed: virtual seconds per wall/CPU second on a scenario, and peak memory.

    .venv/bin/python bench/bench_sim.py [SCENARIO] [--runs N]

Prints, per run, the virtual time simulated and the wall and CPU time the run itself took
(imports and start-up excluded, reported separately), the speed factor (virtual / wall and
virtual / CPU; target >= 200x on square), and the process's peak RSS.
"""

from __future__ import annotations

import argparse
import resource
import statistics
import sys
import tempfile
import time
from pathlib import Path


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("scenario", nargs="?", default="square")
    parser.add_argument("--runs", type=int, default=3)
    opts = parser.parse_args()

    t0_wall, t0_cpu = time.perf_counter(), time.process_time()
    from robotd import sim_runner
    from robotd.sim_console import SimConsole

    import_wall = time.perf_counter() - t0_wall
    import_cpu = time.process_time() - t0_cpu
    print(f"imports: wall {import_wall * 1000:.0f} ms, cpu {import_cpu * 1000:.0f} ms")

    from hal.sim.scenario import load_scenario
    from robotd import vclock

    scenario = load_scenario(opts.scenario)
    wall_factors, cpu_factors = [], []
    for i in range(opts.runs):
        args = argparse.Namespace(scenario=opts.scenario, seed=i + 1, realtime=False, speed=None,
                                  report=None, quiet=True, socket=None, config=None, mcu="fake")
        console = SimConsole(quiet=True)
        w0, c0 = time.perf_counter(), time.process_time()
        with tempfile.TemporaryDirectory(prefix="bench-sim-") as workdir:
            result = vclock.run(sim_runner._run(args, scenario, console, Path(workdir)))
        wall, cpu = time.perf_counter() - w0, time.process_time() - c0
        if isinstance(result, int):
            print(f"run {i + 1}: could not run (exit {result})")
            return 1
        wall_factors.append(result.sim_s / wall)
        cpu_factors.append(result.sim_s / cpu)
        print(f"run {i + 1}: {'ok' if result.ok else 'FAILED'}  virtual {result.sim_s:.1f} s  "
              f"wall {wall:.3f} s  cpu {cpu:.3f} s  speed x{result.sim_s / wall:.0f} (wall) "
              f"x{result.sim_s / cpu:.0f} (cpu)")
    rss_mib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"speed factor median: x{statistics.median(wall_factors):.0f} wall, "
          f"x{statistics.median(cpu_factors):.0f} cpu (target >= 200x)")
    print(f"peak RSS: {rss_mib:.0f} MiB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
