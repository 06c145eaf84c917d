"""A recorded drive through the cabinet robot's site, to make its map from (issue 30).

``python -m sim.robots.cabinet.site_recording OUT.clf`` drives the simulated robot (with the
LD19's beams, noise and reach, and slipping wheels: ``sim.mapping.depot_run``) round the lab,
through the door to the store, out to the hall and back through the lab's hall door, over its
first metres again so the loop closes, and writes the scans, odometry and true poses as a
CARMEN log. ``robotd map --from-log OUT.clf --out NAME`` then makes the map the site file
``made/site.json`` lays its rooms, doors and cabinets on:

    .venv/bin/python -m sim.robots.cabinet.site_recording /tmp/cabinet-site.clf
    .venv/bin/robotd map --from-log /tmp/cabinet-site.clf \\
        --out sim/robots/cabinet/scenarios/cabinet/made/site

The world is the site as it stood when mapped: its walls and cabinets, every door open, none
of the furniture the scenarios add.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from sim.mapping.depot_run import record_run, write_recording
from sim.robots.cabinet.site_world import expand_site_map
from sim.world.floor_plan import World

SCENARIO_DIR = Path(__file__).resolve().parent / "scenarios"
SITE = "cabinet/site.json"
ROUTE: tuple[tuple[float, float], ...] = (
    (2.5, 2.0), (4.3, 2.0), (6.0, 2.0), (8.0, 2.0), (8.0, 3.0), (8.0, 5.0), (5.0, 5.0),
    (2.0, 5.0), (2.0, 3.0), (1.2, 2.0), (1.2, 1.8), (2.5, 2.0), (4.3, 2.0))
"""Lab → door ab → store → door b-hall → hall → door a-hall → lab, and on to where the
loop began."""


def site_world() -> World:
    table = expand_site_map({"site_map": SITE}, SCENARIO_DIR)
    return World.from_table(table, base_dir=SCENARIO_DIR)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m sim.robots.cabinet.site_recording",
                                     description="record a drive through the cabinet site "
                                                 "as a CARMEN log")
    parser.add_argument("out", type=Path)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args(argv)
    recording = record_run(ROUTE, world=site_world(), seed=args.seed, speed_mps=0.3)
    write_recording(recording, args.out)
    print(f"{args.out}: {len(recording.scans)} scans, {recording.distance_m:.1f} m in "
          f"{recording.duration_s:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
