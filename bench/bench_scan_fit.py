"""Scan-to-map fit (``behaviours/nav/scan_match.py``) accuracy and cost: figures, not pass/fail.

    .venv/bin/python bench/bench_scan_fit.py [--trials N] [--seed S] [--json]

The map is the cabinet robot's example site (``behaviours/profiles/cabinet/examples/
site.json``: a lab and a store joined by a door, a hall, four cabinets drawn as boxes), at
0.05 m cells. Each trial puts two to four pieces of furniture the map does not know (boxes of
0.3-0.8 m) in the lab, places the robot at a random free pose in the lab, and casts a 450-beam
LD19-like scan (8 m range) with sigma 1 cm range noise and 5 % outliers (a beam cut short at a
random range, as dust or a passing leg does). ``local``: the fit starts from a guess within
0.3 m and 20 degrees of the truth; ``global``: over the whole lab (the start area) at every
heading. Per fit: the position and heading error, whether it was accepted, the wall-clock time.
The global fit is judged honest when no accepted fit is more than 20 cm or 5 degrees off.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import time
from pathlib import Path
from typing import Any

import numpy as np

from behaviours.nav.distance_field import DistanceField
from behaviours.nav.scan_match import MatchConfig, ScanMatcher
from behaviours.profiles.cabinet.map_reader import parse_site_map
from behaviours.profiles.cabinet.site_map import SiteMap
from sim.world.geometry import raycast

SITE = Path(__file__).parents[1] / "behaviours" / "profiles" / "cabinet" / "examples" / "site.json"
START_AREA = (0.0, 0.0, 5.0, 4.0)
BEAMS = 450
MAX_RANGE_M = 8.0
NOISE_M = 0.01
OUTLIERS = 0.05


def load_site() -> SiteMap:
    return parse_site_map(json.loads(SITE.read_text()), "site.json")


def box(x: float, y: float, w: float, h: float) -> list[tuple[float, float, float, float]]:
    return [(x, y, x + w, y), (x + w, y, x + w, y + h), (x + w, y + h, x, y + h),
            (x, y + h, x, y)]


def furniture(rng: np.random.Generator) -> list[tuple[float, float, float, float]]:
    out = []
    for _ in range(int(rng.integers(2, 5))):
        w, h = rng.uniform(0.3, 0.8, size=2)
        x, y = rng.uniform(0.6, 4.4 - w), rng.uniform(0.6, 3.4 - h)
        out += box(float(x), float(y), float(w), float(h))
    return out


def scan(rng: np.random.Generator, segments: np.ndarray, pose: tuple[float, float, float]
         ) -> np.ndarray:
    """Robot-frame points of one noisy scan (beams with no return dropped)."""
    x, y, theta = pose
    angles = np.linspace(0, 2 * math.pi, BEAMS, endpoint=False)
    ranges = raycast(segments, x, y, angles + theta, MAX_RANGE_M)
    hit = ranges < MAX_RANGE_M
    ranges = ranges + rng.normal(0.0, NOISE_M, size=ranges.shape)
    cut = rng.random(ranges.shape) < OUTLIERS
    ranges[cut] = rng.uniform(0.05, 1.0, size=int(cut.sum())) * ranges[cut]
    ranges, angles = ranges[hit], angles[hit]
    return np.stack([ranges * np.cos(angles), ranges * np.sin(angles)], axis=1)


def free_pose(rng: np.random.Generator, field: DistanceField, extra: np.ndarray
              ) -> tuple[float, float, float]:
    while True:
        x, y = rng.uniform(0.4, 4.6), rng.uniform(0.4, 3.6)
        if field.at(x, y) < 0.3:
            continue
        if extra.size and _near_segments(extra, x, y) < 0.3:
            continue
        return (float(x), float(y), float(rng.uniform(-math.pi, math.pi)))


def _near_segments(segs: np.ndarray, x: float, y: float) -> float:
    start, end = segs[:, :2], segs[:, 2:]
    d = end - start
    t = np.clip(((x - start[:, 0]) * d[:, 0] + (y - start[:, 1]) * d[:, 1])
                / np.maximum((d * d).sum(axis=1), 1e-12), 0, 1)
    px, py = start[:, 0] + t * d[:, 0], start[:, 1] + t * d[:, 1]
    return float(np.hypot(px - x, py - y).min())


def errors(fit_pose: tuple[float, float, float], truth: tuple[float, float, float]
           ) -> tuple[float, float]:
    dtheta = math.atan2(math.sin(fit_pose[2] - truth[2]), math.cos(fit_pose[2] - truth[2]))
    return math.hypot(fit_pose[0] - truth[0], fit_pose[1] - truth[1]), abs(math.degrees(dtheta))


def run(trials: int, seed: int, config: MatchConfig) -> dict[str, Any]:
    site = load_site()
    grid = site.grid()
    field = DistanceField(grid)
    walls = site.wall_array()
    matcher = ScanMatcher(field, walls, config)
    rng = np.random.default_rng(seed)
    local: list[tuple[float, float, float, bool]] = []
    glob: list[tuple[float, float, float, bool, str]] = []
    for _ in range(trials):
        extra = np.asarray(furniture(rng), dtype=np.float64)
        world = np.vstack([walls, extra])
        truth = free_pose(rng, field, extra)
        points = scan(rng, world, truth)
        r, a = rng.uniform(0, 0.3), rng.uniform(-math.pi, math.pi)
        guess = (truth[0] + r * math.cos(a), truth[1] + r * math.sin(a),
                 truth[2] + math.radians(rng.uniform(-20, 20)))
        t0 = time.perf_counter()
        fit = matcher.fit_local(points, guess)
        dt = time.perf_counter() - t0
        e_m, e_deg = errors(fit.pose, truth)
        local.append((e_m, e_deg, dt, fit.accepted))
        t0 = time.perf_counter()
        fit = matcher.fit_global(points, START_AREA)
        dt = time.perf_counter() - t0
        e_m, e_deg = errors(fit.pose, truth)
        glob.append((e_m, e_deg, dt, fit.accepted, fit.reason))
    return {"trials": trials, "seed": seed, "local": summary(local), "global": gsummary(glob)}


def pct(values: list[float], q: float) -> float:
    return float(np.percentile(np.asarray(values), q))


def summary(rows: list[tuple[float, float, float, bool]]) -> dict[str, Any]:
    e_m = [r[0] for r in rows]
    e_deg = [r[1] for r in rows]
    t_ms = [r[2] * 1000 for r in rows]
    return {"accepted": sum(r[3] for r in rows),
            "error_cm_p50": round(100 * statistics.median(e_m), 2),
            "error_cm_p95": round(100 * pct(e_m, 95), 2),
            "error_deg_p50": round(statistics.median(e_deg), 3),
            "error_deg_p95": round(pct(e_deg, 95), 3),
            "time_ms_p50": round(statistics.median(t_ms), 2),
            "time_ms_p95": round(pct(t_ms, 95), 2)}


def gsummary(rows: list[tuple[float, float, float, bool, str]]) -> dict[str, Any]:
    accepted = [r for r in rows if r[3]]
    good = [r for r in accepted if r[0] <= 0.2 and r[1] <= 5.0]
    wrong = [r for r in accepted if not (r[0] <= 0.2 and r[1] <= 5.0)]
    refused_right = sum(1 for r in rows if not r[3] and r[0] <= 0.2 and r[1] <= 5.0)
    t_ms = [r[2] * 1000 for r in rows]
    return {"found_pct": round(100 * len(good) / len(rows), 1),
            "wrong_accepted": len(wrong),
            "refused": len(rows) - len(accepted),
            "refused_but_right": refused_right,
            "refusal_reasons": sorted({r[4].split(":")[0] for r in rows if not r[3]}),
            "error_cm_p50_found": round(100 * statistics.median([r[0] for r in good]), 2)
            if good else None,
            "time_ms_p50": round(statistics.median(t_ms), 1),
            "time_ms_p95": round(pct(t_ms, 95), 1)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=200)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    result = run(args.trials, args.seed, MatchConfig())
    if args.json:
        print(json.dumps(result))
        return
    for part in ("local", "global"):
        print(part, json.dumps(result[part]))


if __name__ == "__main__":
    main()
