"""A scenario over many seeds: how often it passes, and the spread of its figures.

    .venv/bin/python bench/bench_seeds.py [SCENARIO] [--seeds 1-40] [--config FILE]

Runs ``robotd sim SCENARIO --seed N`` for each seed (in this process, in virtual time) and
prints each run's verdict and its robots' figures, then how many passed, the reasons of those
that did not, and min / median / max of each figure over the runs: arrival distances
(``arrival_<room>_m``), cross-track error, distance driven. Sensor noise differs from seed to
seed, so one passing seed says little; this says how robust a scenario and the robot's
settings are. ``--config`` lays a robot config over the scenario's (as ``robotd sim
--config``), e.g. to compare a setting's values on the same seeds.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import statistics
import sys
import tempfile
from collections import defaultdict
from pathlib import Path
from typing import Any

from robotd.cli import main as robotd_main


def seeds(text: str) -> list[int]:
    """``1-40`` or ``3,5,8`` (or both, comma-separated)."""
    out: list[int] = []
    for part in text.split(","):
        first, _, last = part.partition("-")
        out += range(int(first), int(last or first) + 1)
    return out


def run(scenario: str, seed: int, config: str | None) -> dict[str, Any]:
    """One run's result event (ok, reasons, figures per robot)."""
    with tempfile.TemporaryDirectory() as out:
        args = ["sim", scenario, "--quiet", "--seed", str(seed), "--report", out]
        if config:
            args += ["--config", config]
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            robotd_main(args)
        lines = (Path(out) / "events.jsonl").read_text().splitlines()
    result: dict[str, Any] = json.loads(lines[-1])
    return result


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("scenario", nargs="?", default="laundry-loop")
    parser.add_argument("--seeds", default="1-40")
    parser.add_argument("--config", help="robot config laid over the scenario's")
    opts = parser.parse_args()
    figures: dict[str, list[float]] = defaultdict(list)
    failed: list[tuple[int, list[str]]] = []
    chosen = seeds(opts.seeds)
    for seed in chosen:
        result = run(opts.scenario, seed, opts.config)
        shown = []
        for robot, values in sorted(result["figures"].items()):
            for key, value in sorted(values.items()):
                if key.startswith("arrival_") or key in ("mean_cross_track_cm", "distance_m",
                                                             "max_arrival_error_cm", "fits_tried"):
                    figures[key].append(float(value))
                    shown.append(f"{robot} {key} {value}")
        print(f"seed {seed:3d}: {'ok    ' if result['ok'] else 'FAILED'}  {', '.join(shown)}")
        if not result["ok"]:
            failed.append((seed, result["reasons"]))
        sys.stdout.flush()
    print(f"\n{opts.scenario}{' with ' + opts.config if opts.config else ''}: "
          f"{len(chosen) - len(failed)} of {len(chosen)} seeds passed")
    for seed, reasons in failed:
        print(f"  seed {seed}: {'; '.join(reasons)}")
    for key, values in sorted(figures.items()):
        print(f"  {key:22s} min {min(values):.2f}  median {statistics.median(values):.2f}  "
              f"max {max(values):.2f}  ({len(values)} values)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
