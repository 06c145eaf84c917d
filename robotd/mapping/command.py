"""``robotd map``: the robot maps its site live; ``--from-log FILE --out NAME [--trajectory OUT]``
maps a recorded log offline.

Without ``--from-log`` it is ``robotd run`` with the ``survey`` profile (``robotd.cli``): the
robot's real drivers (its LD19, its motor board's wheel odometry) feed the mapping core live,
a technician drives it with ``robotctl drive`` and saves the map with ``robotctl map save
NAME``; ``robotctl status`` shows the key scans, the loops closed and the map's size.

Reads a CARMEN ``.clf`` log (``robotd.mapping.clf``), maps it (``behaviours.nav.mapping``) as
fast as it can, writes the map as ``NAME.pgm`` + ``NAME.yaml`` and, with ``--trajectory``, the
optimised pose of every scan as ``timestamp x y theta`` lines. Unreadable lines are skipped;
their count (and the first few, with line numbers) is printed at the end. A log that holds
``TRUEPOS`` lines (the simulator's) also gets the relation error against them printed.
Exit 0 when a map was written, 1 when the log had no scan, 2 when it cannot be read.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import structlog

from behaviours.nav.icp import Pose
from robotd.mapping.clf import FLASER_MAX_RANGE_M, ClfLog, read_clf

HELP = "make a map: live on the robot (robotctl drive, robotctl map save) or from a log"
log = structlog.get_logger(__name__)
SHOWN_SKIPPED = 5


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--config", help="live: the robot's config file (default "
                        "$ROBOTD_CONFIG or /etc/robotd/robotd.toml)")
    parser.add_argument("--from-log", metavar="FILE",
                        help="map a recorded log instead of the live robot: a CARMEN .clf "
                             "(FLASER / ROBOTLASER1 lines) or our own run.mcap (/scan, /odom)")
    parser.add_argument("--out", metavar="NAME",
                        help="writes NAME.pgm and NAME.yaml (map_saver's trinary format)")
    parser.add_argument("--trajectory", metavar="OUT",
                        help="writes every scan's optimised pose: 'timestamp x y theta' lines")
    parser.add_argument("--flaser-max-range-m", type=float, default=FLASER_MAX_RANGE_M,
                        help="FLASER's no-return range (default %(default)s m)")
    parser.add_argument("--resolution-m", type=float, default=0.05,
                        help="the map's cell (default %(default)s m)")
    parser.add_argument("--log-level", default="warning",
                        help="structured log events shown on stderr (default %(default)s; "
                             "info shows each loop closure)")


def run(args: argparse.Namespace) -> int:
    """``robotd map --from-log``; the live mode is ``robotd.cli``'s (it runs the daemon)."""
    if not args.out:
        print("robotd map: --from-log needs --out NAME", file=sys.stderr)
        return 2
    # SciPy and the matcher are loaded here, not when the command line is built.
    from behaviours.nav.mapping.map_save import write_map
    from behaviours.nav.mapping.mapper import MappingConfig, build_map
    from robotd.logs import configure_logging

    configure_logging(args.log_level)
    started = time.perf_counter()
    try:
        if str(args.from_log).endswith(".mcap"):  # our own recording (robotd/viz)
            from robotd.mapping.mcap_log import read_mcap

            recorded = read_mcap(args.from_log)
        else:
            recorded = read_clf(args.from_log, flaser_max_range_m=args.flaser_max_range_m)
    except OSError as exc:
        print(f"robotd map: {args.from_log}: {exc.strerror or exc}", file=sys.stderr)
        return 2
    read_s = time.perf_counter() - started
    if not recorded.scans:
        wanted = ("/scan with /odom, taken standing" if str(args.from_log).endswith(".mcap")
                  else "FLASER or ROBOTLASER1 scan")
        print(f"robotd map: {args.from_log}: no {wanted} in the log", file=sys.stderr)
        _print_skipped(args.from_log, recorded)
        return 1
    result = build_map(recorded.scans, MappingConfig(resolution_m=args.resolution_m))
    yaml = write_map(result.grid, args.out)
    if args.trajectory:
        _write_trajectory(Path(args.trajectory), recorded, result.scan_poses)
    total_s = time.perf_counter() - started
    span_s = recorded.scans[-1].timestamp_s - recorded.scans[0].timestamp_s
    print(f"{args.from_log}: {len(recorded.scans)} scans over {span_s:.1f} s, "
          f"{len(result.key_indices)} key scans ({result.matches_accepted} matched, "
          f"{result.matches_refused} on odometry), {result.graph.loop_closures()} loop "
          f"closures of {result.loops_tried} tried; {total_s:.1f} s "
          f"(read {read_s:.1f} s)")
    print(f"map: {yaml} ({result.grid.width} x {result.grid.height} cells of "
          f"{result.grid.resolution_m} m)")
    _print_truth(recorded, result.key_indices, result.key_poses)
    _print_skipped(args.from_log, recorded)
    log.info("mapping.done", scans=len(recorded.scans), key_scans=len(result.key_indices),
             loops=result.graph.loop_closures(), skipped_lines=len(recorded.skipped),
             seconds=round(total_s, 2))
    return 0


def _write_trajectory(path: Path, recorded: ClfLog, poses: list[Pose]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", encoding="ascii") as out:
        for scan, (x, y, theta) in zip(recorded.scans, poses, strict=True):
            out.write(f"{scan.timestamp_s:.6f} {x:.6f} {y:.6f} {theta:.6f}\n")


def _print_truth(recorded: ClfLog, key_indices: list[int], key_poses: list[Pose]) -> None:
    truth = dict(recorded.true_poses)
    pairs = [(pose, truth[recorded.scans[k].timestamp_s])
             for k, pose in zip(key_indices, key_poses, strict=True)
             if recorded.scans[k].timestamp_s in truth]
    if len(pairs) < 2:
        return
    from behaviours.nav.mapping.metrics import relation_error

    est, true = [p for p, _ in pairs], [t for _, t in pairs]
    for kind in ("consecutive", "all"):
        e = relation_error(est, true, pairs=kind)
        print(f"relation error against TRUEPOS ({kind} key-scan pairs, {e.pairs}): "
              f"{e.translation_m * 100:.2f} cm, {math.degrees(e.rotation_rad):.3f} deg "
              f"(worst {e.translation_max_m * 100:.1f} cm, "
              f"{math.degrees(e.rotation_max_rad):.2f} deg)")


def _print_skipped(source: str, recorded: ClfLog) -> None:
    print(f"unreadable lines skipped: {len(recorded.skipped)}")
    for number, why in recorded.skipped[:SHOWN_SKIPPED]:
        print(f"  {source}:{number}: {why}")
    if len(recorded.skipped) > SHOWN_SKIPPED:
        print(f"  ... and {len(recorded.skipped) - SHOWN_SKIPPED} more")
