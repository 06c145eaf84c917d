"""``robotd probe lidar``: watch the LD19 through the real driver and print its figures.

    robotd probe lidar --port /dev/ttyUSB0                 # 5 s of scans
    robotd probe lidar --port P --seconds 10 --json
    robotd probe lidar --sim --corrupt 1                   # a simulated LD19, 1 % bad bytes

Opens the port (``--config``'s ``lidar`` section, or the options), waits for the first
intact packet, reads for ``--seconds`` and prints the scan rate, points per scan, packets,
CRC errors, resyncs, skipped bytes, timestamp gaps, and what it sees ahead. Exit 0 when at
least one whole scan arrived and the LiDAR was not stale at the end, 1 otherwise, 2 for
bad options.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import math
import sys
from typing import Any

import numpy as np

from drivers.lidar import Ld19Lidar, LidarConfig
from drivers.lidar.packet import Model
from hal.devices import DeviceUnavailable
from hal.ports import SerialOpener
from hal.readings import LidarScan
from robotd.config.errors import ConfigError
from robotd.config.loader import defaults, load_config
from robotd.config.settings import Settings
from robotd.probes import run_standalone, simulator

# The simulated LD19's room: a wall 1 m ahead, 2 m left, 3 m right and behind.
SIM_ROOM = [(1.0, -3.0, 1.0, 2.0), (-3.0, 2.0, 1.0, 2.0), (-3.0, -3.0, 1.0, -3.0),
            (-3.0, -3.0, -3.0, 2.0)]
AHEAD_DEG = 5.0


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--config", help="take the lidar section from this robotd.toml")
    parser.add_argument("--port", help="serial device (lidar.port)")
    parser.add_argument("--baud", type=int, help="baud rate (lidar.baud)")
    parser.add_argument("--model", choices=[m.value for m in Model], help="lidar.model")
    parser.add_argument("--seconds", type=float, default=5.0,
                        help="how long to read after the first packet (default 5)")
    parser.add_argument("--sim", action="store_true",
                        help="read a simulated LD19 in a small room (virtual time)")
    parser.add_argument("--corrupt", type=float, default=0.0, metavar="PCT",
                        help="with --sim: flip a bit in this %% of bytes")
    if "--json" not in parser._option_string_actions:
        parser.add_argument("--json", action="store_true", help="print one JSON object")


def _config(args: argparse.Namespace) -> LidarConfig:
    values = load_config(args.config) if args.config else defaults()
    for key in ("port", "baud", "model"):
        if getattr(args, key) is not None:
            values["lidar"][key] = getattr(args, key)
    settings = Settings(values)
    for key in ("port", "baud", "model"):
        settings.check(f"lidar.{key}", values["lidar"][key])
    return LidarConfig.from_settings(settings)


def _sim_opener(config: LidarConfig, corrupt_pct: float) -> SerialOpener:
    opener: SerialOpener = simulator().ld19_ports(SIM_ROOM, config.model.value, config.port,
                                                  corrupt_pct)
    return opener


async def run(args: argparse.Namespace) -> int:
    try:
        config = _config(args)
    except (ConfigError, ValueError) as exc:
        print(f"probe lidar: {exc}", file=sys.stderr)
        return 2
    if not (args.seconds > 0 and math.isfinite(args.seconds)):
        print(f"probe lidar: --seconds: expected seconds (> 0), got {args.seconds}",
              file=sys.stderr)
        return 2
    if args.sim:
        opener: SerialOpener = _sim_opener(config, args.corrupt)
    else:
        from drivers.serial_port import open_serial

        opener = open_serial
    lidar = Ld19Lidar(opener, config, name="probe")
    try:
        await lidar.start()
    except DeviceUnavailable as exc:
        print(f"probe lidar: {exc}", file=sys.stderr)
        return 1
    try:
        report = await watch(lidar, args.seconds)
    finally:
        await lidar.close()
    if args.json:
        print(json.dumps(report))
    else:
        _print(report)
    return 0 if report["scans"] > 0 and not report["stale"] else 1


async def watch(lidar: Ld19Lidar, seconds: float) -> dict[str, Any]:
    """Read for ``seconds``; the driver's figures and what the last scan saw."""
    loop = asyncio.get_running_loop()
    start_s = loop.time()
    await asyncio.sleep(seconds)
    report: dict[str, Any] = {"duration_s": round(loop.time() - start_s, 3), **lidar.status()}
    report.update(_sight(lidar.latest()))
    return report


def _sight(scan: LidarScan | None) -> dict[str, Any]:
    """Range straight ahead (median within 5 deg) and the nearest point, of one scan."""
    if scan is None or not bool(scan.valid.any()):
        return {"ahead_m": None, "nearest_m": None, "nearest_deg": None}
    valid = scan.valid
    angles, ranges = scan.angles_rad[valid], scan.ranges_m[valid]
    ahead = ranges[np.abs(angles) <= math.radians(AHEAD_DEG)]
    nearest = int(np.argmin(ranges))
    return {"ahead_m": round(float(np.median(ahead)), 3) if len(ahead) else None,
            "nearest_m": round(float(ranges[nearest]), 3),
            "nearest_deg": round(math.degrees(float(angles[nearest])), 1)}


def _print(r: dict[str, Any]) -> None:
    print(f"{r['port']} ({r['model']}): {r['scans']} scans in {r['duration_s']} s, "
          f"{r['scan_rate_hz']} Hz, {r['points_per_scan']} points/scan "
          f"({r['valid_points']} valid){', STALE' if r['stale'] else ''}")
    print(f"packets {r['packets']} ({r['bytes']} bytes): CRC errors {r['crc_errors']}, "
          f"implausible {r['implausible']}, resyncs {r['resyncs']}, "
          f"skipped {r['skipped_bytes']} bytes")
    print(f"sensor timestamps: last gap {r['last_gap_ms']} ms, max gap {r['max_gap_ms']} ms, "
          f"~{r['lost_packets']} packets lost; reconnects {r['reconnects']}")
    if r["nearest_m"] is not None:
        print(f"ahead {r['ahead_m']} m; nearest {r['nearest_m']} m at {r['nearest_deg']} deg")


def main(argv: list[str] | None = None) -> int:
    return run_standalone("robotd probe lidar", __doc__, add_arguments, run, argv)


if __name__ == "__main__":
    sys.exit(main())
