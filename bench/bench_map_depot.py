"""The ``map-depot`` scenario end to end, its figures beside odometry alone, and its images.

Runs ``robotd sim map-depot`` in this process (the survey explores Nav2's depot from scratch,
saves the map, hands over to the patrol that drives its goals on it) with the maps directory
kept (``--config`` sets ``survey.maps_dir``), then prints the relation error over all key-scan
pairs and the map quality against the depot's true cells, for the optimised key poses and,
as the baseline from the same run, the relation error of the key scans at their odometry
poses (their map is not drawn: the events do not hold the scans), the patrol's goal errors,
and the wall time.

    .venv/bin/python bench/bench_map_depot.py [--seed 1] [--images docs] [--json]

``--images DIR`` writes ``mapping-depot-live.png`` and ``mapping-depot-live-error.png``.
"""

from __future__ import annotations

import argparse
import json
import math
import tempfile
import time
from pathlib import Path
from typing import Any

from behaviours.nav.mapping.metrics import map_quality, relation_error
from hal.occupancy_map import read_map_yaml
from sim.mapping.depot_run import MAPS_DIR


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--images", metavar="DIR")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    from robotd.cli import main as robotd

    with tempfile.TemporaryDirectory(prefix="map-depot-") as tmp:
        work = Path(tmp)
        config = work / "keep.toml"
        config.write_text(f'[survey]\nmaps_dir = "{work / "maps"}"\n', encoding="utf-8")
        started = time.perf_counter()
        code = robotd(["sim", "map-depot", "--seed", str(args.seed), "--quiet",
                       "--config", str(config), "--report", str(work / "report")])
        wall_s = time.perf_counter() - started
        events = [json.loads(line) for line in
                  (work / "report" / "events.jsonl").read_text().splitlines()]
        figures = _figures(events, work / "maps" / "depot-made.yaml", args.images)
    figures.update(exit=code, wall_s=round(wall_s, 1))
    if args.json:
        print(json.dumps(figures))
        return
    for key, value in figures.items():
        print(f"{key:26s} {value}")


def _figures(events: list[dict[str, Any]], made_yaml: Path, images: str | None
             ) -> dict[str, Any]:
    saved = [e for e in events if e["kind"] == "mapping.saved"][-1]
    keys = {int(e["key"]): e for e in events if e["kind"] == "mapping.key_scan"}
    truth = [(keys[k]["x_m"], keys[k]["y_m"], math.radians(keys[k]["true_heading_deg"]))
             for k in range(len(saved["key_poses"]))]
    odometry = [(keys[k]["odom_x_m"], keys[k]["odom_y_m"],
                 math.radians(keys[k]["odom_heading_deg"]))
                for k in range(len(saved["key_poses"]))]
    mapped = [tuple(p) for p in saved["key_poses"]]
    true_map = read_map_yaml(MAPS_DIR / "depot.yaml")
    made = read_map_yaml(made_yaml)
    out: dict[str, Any] = {"key_scans": saved["key_scans"],
                           "loops_closed": saved["loops_closed"],
                           "distance_m": round([e for e in events if e["kind"] == "result"][-1][
                               "figures"]["sim-1"]["distance_m"], 1)}
    for name, poses in (("mapping", mapped), ("odometry", odometry)):
        e = relation_error(poses, truth, pairs="all")
        out[f"{name}_all"] = {"cm": round(e.translation_m * 100, 2),
                              "deg": round(math.degrees(e.rotation_rad), 3),
                              "worst_cm": round(e.translation_max_m * 100, 1)}
    q = map_quality(made, true_map)
    out["mapping_map"] = {"occupied_near_wall_pct": round(q.occupied_near_wall_pct, 2),
                          "free_truly_free_pct": round(q.free_truly_free_pct, 2)}
    reached = [e for e in events if e["kind"] == "nav.goal_reached"]
    out["goal_errors_cm"] = [round(math.hypot(e["goal_x_m"] - e["x_m"],
                                              e["goal_y_m"] - e["y_m"]) * 100, 1)
                             for e in reached]
    if images:
        from mapping_images import write_images  # matplotlib only when asked (bench/)

        write_images(images, made, true_map, truth, mapped, odometry, out,
                     prefix="mapping-depot-live", drive="exploration")
    return out


if __name__ == "__main__":
    main()
