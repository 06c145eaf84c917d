"""The cabinet robot from random start poses: how often the fitting phase finds the pose, how
many attempts (turns) it takes, whether any fit it accepts is wrong, and the arrival error.

Each trial is the ``cabinet`` scenario's site and settings (a 120 degree usable view,
``fit_min_score`` 0.75, two unmapped boxes) with the robot put down at a random free pose in
any room, at any heading, and one task (cabinet c3); the robot is never told where it is.
A fit is wrong when the pose it reports (``fit.found``) is more than 20 cm from the truth.

    .venv/bin/python bench/bench_cabinet_starts.py --trials 20 --seed 1
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import math
import statistics
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from behaviours.nav.distance_field import DistanceField
from behaviours.profiles.cabinet.map_reader import parse_site_map
from robotd.cli import main as robotd_main

SCENARIOS = Path(__file__).parents[1] / "sim" / "robots" / "cabinet" / "scenarios"
SITE = SCENARIOS / "cabinet" / "site.json"
BOXES = ((1.0, 2.9, 1.4, 3.3), (6.6, 0.6, 7.2, 1.0))
WRONG_M = 0.20


def start_pose(rng: np.random.Generator, field: DistanceField) -> tuple[float, float, float]:
    """A free pose 0.4 m from every wall and box, any heading."""
    while True:
        x, y = float(rng.uniform(0.3, 9.7)), float(rng.uniform(0.3, 5.7))
        if field.at(x, y) < 0.4:
            continue
        if any(x0 - 0.4 < x < x1 + 0.4 and y0 - 0.4 < y < y1 + 0.4 for x0, y0, x1, y1 in BOXES):
            continue
        return x, y, float(rng.uniform(-180.0, 180.0))


def scenario_text(pose: tuple[float, float, float], tasks: Path) -> str:
    boxes = ", ".join(f"{{ x_min_m = {b[0]}, y_min_m = {b[1]}, x_max_m = {b[2]}, "
                      f"y_max_m = {b[3]}, mapped = false }}" for b in BOXES)
    return f"""
[scenario]
name = "cabinet-start"
profile = "cabinet"
[config.cabinet]
map_file = "{SITE}"
task_file = "{tasks}"
fit_fov_deg = 120.0
fit_min_view_deg = 250.0
fit_min_score = 0.75
[config.localisation]
update_min_d_m = 0.1
update_min_a_deg = 5.0
[world]
site_map = "{SITE}"
boxes = [{boxes}]
[robot]
x_m = {pose[0]:.3f}
y_m = {pose[1]:.3f}
heading_deg = {pose[2]:.1f}
[success]
time_limit_s = 400
final_state = "idle"
cabinets_in_order = ["c3"]
max_arrival_error_m = 0.10
"""


def trial(pose: tuple[float, float, float], seed: int, work: Path) -> dict[str, Any]:
    scenario = work / f"start-{seed}.toml"
    scenario.write_text(scenario_text(pose, work / "tasks.json"))
    out = work / f"out-{seed}"
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        robotd_main(["sim", str(scenario), "--quiet", "--seed", str(seed), "--report", str(out)])
    events = [json.loads(line) for line in (out / "events.jsonl").read_text().splitlines()]
    tried = [e for e in events if e["kind"] == "fit.tried"]
    found = [e for e in events if e["kind"] == "fit.found"]
    errors = [math.hypot(e["est_x_m"] - e["x_m"], e["est_y_m"] - e["y_m"]) for e in found]
    return {"ok": events[-1]["ok"], "reasons": events[-1]["reasons"], "tried": len(tried),
            "turns": sum(1 for e in events if e["kind"] == "fit.change_orientation"),
            "found": len(found), "fit_errors_m": errors,
            "arrival_cm": events[-1]["figures"].get("sim-1", {}).get("max_arrival_error_cm")}


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--trials", type=int, default=20)
    parser.add_argument("--seed", type=int, default=1)
    opts = parser.parse_args()
    site = parse_site_map(json.loads(SITE.read_text()), "site.json")
    field = DistanceField(site.grid())
    rng = np.random.default_rng(opts.seed)
    results = []
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        (work / "tasks.json").write_text(json.dumps({"tasks": [{"cabinet": "c3"}]}))
        for i in range(opts.trials):
            pose = start_pose(rng, field)
            r = trial(pose, opts.seed * 1000 + i, work)
            results.append(r)
            wrong = sum(1 for e in r["fit_errors_m"] if e > WRONG_M)
            print(f"trial {i:3d} start ({pose[0]:.2f}, {pose[1]:.2f}, {pose[2]:6.1f} deg): "
                  f"{'ok    ' if r['ok'] else 'FAILED'} fits tried {r['tried']}, turns "
                  f"{r['turns']}, wrong fits {wrong}, arrival {r['arrival_cm']} cm"
                  + ("" if r["ok"] else f"  ({'; '.join(r['reasons'])})"))
            sys.stdout.flush()
    passed = sum(1 for r in results if r["ok"])
    wrong = sum(1 for r in results for e in r["fit_errors_m"] if e > WRONG_M)
    errors = [e for r in results for e in r["fit_errors_m"]]
    print(f"\n{passed} of {len(results)} trials passed; fits accepted {len(errors)}, wrong "
          f"(> {WRONG_M * 100:.0f} cm) {wrong}; needed a turn "
          f"{sum(1 for r in results if r['turns'])}; fits tried median "
          f"{statistics.median(r['tried'] for r in results)}, max "
          f"{max(r['tried'] for r in results)}")
    if errors:
        print(f"fit error median {statistics.median(errors) * 100:.1f} cm, max "
              f"{max(errors) * 100:.1f} cm")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
