"""Mapping's cost and accuracy on a recorded depot drive, beside odometry alone (issue 30).

Records the simulator's depot drive (``sim/mapping/depot_run.py``: 76 m in 202 s, 5 LD19 scans
a second, the body's wheel slip), maps it with ``behaviours.nav.mapping`` and prints: the time
per key scan (match against the submap) and per loop-closure try (median, p95, worst), the
graph solve and the rendering, the run's length over the mapping's time (the target: faster
than real time on one core), and the relation error (Kümmerle et al. 2009, consecutive and all
key-scan pairs) and map quality against the truth. The baseline, measured in the same run, is
odometry alone: the same key scans at their odometry poses, rendered the same way.

    .venv/bin/python bench/bench_mapping.py [--slip-std 0.01] [--seed 1] [--json]
        [--images DIR]

``--images DIR`` also writes ``mapping-depot.png`` (the map made, with the true, mapped and
odometry trajectories) and ``mapping-depot-error.png`` (each cell of the map made against the
depot's true cells: occupied near a true wall, occupied away from one, free but truly a wall).
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import time

from behaviours.nav.mapping.log_odds import render
from behaviours.nav.mapping.mapper import Mapper
from behaviours.nav.mapping.metrics import map_quality, relation_error
from hal.occupancy_map import read_map_yaml
from sim.mapping.depot_run import MAPS_DIR, record_run


def _ms(values: list[float]) -> dict[str, float]:
    ordered = sorted(values)
    if not ordered:
        return {}
    return {"median_ms": round(statistics.median(ordered) * 1000, 1),
            "p95_ms": round(ordered[min(len(ordered) - 1, int(0.95 * len(ordered)))] * 1000, 1),
            "max_ms": round(ordered[-1] * 1000, 1)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--slip-std", type=float, default=0.01)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--images", metavar="DIR", help="write the map and its error image")
    args = parser.parse_args()
    started = time.perf_counter()
    recording = record_run(seed=args.seed, slip_std=args.slip_std)
    record_s = time.perf_counter() - started
    mapper = Mapper()
    started = time.perf_counter()
    for scan in recording.scans:
        mapper.add(scan)
    result = mapper.finish()
    map_s = time.perf_counter() - started
    keys = [recording.scans[k] for k in result.key_indices]
    truth = [recording.true_poses[s.timestamp_s] for s in keys]
    odometry = [s.odom for s in keys]
    started = time.perf_counter()
    odometry_grid = render(keys, odometry)
    baseline_s = time.perf_counter() - started
    true_map = read_map_yaml(MAPS_DIR / "depot.yaml")
    figures: dict[str, object] = {
        "scans": len(recording.scans), "run_s": round(recording.duration_s, 1),
        "distance_m": round(recording.distance_m, 1), "record_s": round(record_s, 1),
        "key_scans": len(keys), "matched": result.matches_accepted,
        "on_odometry": result.matches_refused, "loops_closed": result.graph.loop_closures(),
        "loops_tried": result.loops_tried, "map_s": round(map_s, 2),
        "faster_than_real_time": round(recording.duration_s / map_s, 1),
        "key_scan": _ms(mapper.key_fits_s), "loop_try": _ms(mapper.loop_fits_s),
        "solve_s": round(result.timings_s["solve_s"], 3),
        "render_s": round(result.timings_s["render_s"], 2),
        "baseline_odometry_render_s": round(baseline_s, 2)}
    for name, poses, grid in (("mapping", result.key_poses, result.grid),
                              ("odometry", odometry, odometry_grid)):
        for pairs in ("consecutive", "all"):
            e = relation_error(poses, truth, pairs=pairs)
            figures[f"{name}_{pairs}"] = {"cm": round(e.translation_m * 100, 2),
                                          "deg": round(math.degrees(e.rotation_rad), 3),
                                          "worst_cm": round(e.translation_max_m * 100, 1)}
        q = map_quality(grid, true_map)
        figures[f"{name}_map"] = {"occupied_near_wall_pct": round(q.occupied_near_wall_pct, 2),
                                  "free_truly_free_pct": round(q.free_truly_free_pct, 2)}
    if args.images:
        from mapping_images import write_images  # matplotlib only when asked (bench/)

        write_images(args.images, result.grid, true_map, truth, result.key_poses, odometry,
                     figures)
    if args.json:
        print(json.dumps(figures))
        return
    for key, value in figures.items():
        print(f"{key:28s} {value}")


if __name__ == "__main__":
    main()
