"""``robotd probe ble``: scan for iBeacons with the real driver and print what each looks like.

Run on the robot: ``robotd probe ble --uuid FDA50693-... --duration-s 10``. ``--sim`` scans a
simulated room instead (one beacon 2 m away), to try the probe without a Bluetooth adapter.
Exit 0 when at least one matching iBeacon was seen, 1 otherwise.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import math
import statistics
import sys
from collections import defaultdict
from typing import Any

from behaviours.beacons.tracker import BeaconTracker
from drivers.ble_scanner import BleBeaconScanner, ScannerFactory, bleak_scanner_factory
from hal.devices import DeviceUnavailable
from hal.readings import BeaconSighting
from robotd.config.settings import Settings
from robotd.probes import run_standalone, simulator

SIM_UUID = "fda50693-a4e2-4fb1-afcf-c6eb07647825"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--uuid", action="append", default=[], metavar="UUID",
                        help="proximity UUID to report (repeatable); default: every iBeacon")
    parser.add_argument("--adapter", default="", help="BlueZ adapter, e.g. hci0")
    parser.add_argument("--duration-s", type=float, default=10.0, help="how long to scan")
    parser.add_argument("--path-loss-exponent", type=float, default=2.0,
                        help="n of d = 10^((TxPower - RSSI) / (10 n))")
    parser.add_argument("--sim", action="store_true",
                        help="scan a simulated room (one beacon 2 m away) instead of the adapter")
    if "--json" not in parser._option_string_actions:
        parser.add_argument("--json", action="store_true", help="print one JSON object")


def _sim_factory(stack: list[Any]) -> ScannerFactory:
    beacons = [{"mac": "C3:00:00:00:01:03", "uuid": SIM_UUID, "major": 1, "minor": 103,
                "x_m": 4.0, "y_m": 2.0, "room": "103"}]
    factory: ScannerFactory = simulator().ble_scanners(beacons, stack)
    return factory


async def run(args: argparse.Namespace) -> int:
    sims: list[Any] = []
    factory = _sim_factory(sims) if args.sim else bleak_scanner_factory(args.adapter)
    try:
        scanner = BleBeaconScanner(args.uuid, scanner_factory=factory)
    except ValueError as exc:
        print(f"probe ble: --uuid: {exc}", file=sys.stderr)
        return 2
    problem = _bad_option(args)
    if problem:
        print(f"probe ble: {problem}", file=sys.stderr)
        return 2
    tracker = BeaconTracker(scanner, path_loss_exponent=args.path_loss_exponent,
                            removal_timeout_s=max(10.0, args.duration_s + 1))
    rssi: dict[str, list[int]] = defaultdict(list)

    def record(s: BeaconSighting) -> None:
        rssi[s.mac].append(s.rssi_dbm)

    scanner.on_sighting(record)
    air_task = asyncio.create_task(sims[0].run()) if sims else None
    try:
        await scanner.start()
    except DeviceUnavailable as exc:
        print(f"probe ble: {exc}", file=sys.stderr)
        return 1
    try:
        await asyncio.sleep(args.duration_s)
    finally:
        await scanner.close()
        if air_task is not None:
            air_task.cancel()
    report = _report(tracker, rssi, scanner.status(), args.duration_s)
    if args.json:
        print(json.dumps(report))
    else:
        _print_table(report)
    if not report["beacons"]:
        if not args.json:
            print(f"no matching iBeacon seen in {args.duration_s:g} s", file=sys.stderr)
        return 1
    return 0


def _bad_option(args: argparse.Namespace) -> str | None:
    """Why the numeric options cannot be used, or None; n is checked like the config's."""
    if not (args.duration_s > 0 and math.isfinite(args.duration_s)):
        return f"--duration-s: expected a number of seconds > 0, got {args.duration_s}"
    _, error = Settings.option("ble.path_loss_exponent").check(args.path_loss_exponent)
    return None if error is None else f"--path-loss-exponent: {error}"


def _report(tracker: BeaconTracker, rssi: dict[str, list[int]], status: dict[str, Any],
            duration_s: float) -> dict[str, Any]:
    beacons = []
    for b in tracker.tracked():
        values = rssi.get(b.mac, [])
        beacons.append({
            "mac": b.mac, "uuid": b.uuid, "major": b.major, "minor": b.minor,
            "tx_power_dbm": b.tx_power_dbm, "sightings": b.sightings,
            "rate_hz": round(b.sightings / duration_s, 2),
            "rssi_dbm": round(b.smoothed_rssi_dbm, 1),
            "rssi_min_dbm": min(values, default=None), "rssi_max_dbm": max(values, default=None),
            "rssi_std_db": round(statistics.pstdev(values), 2) if values else None,
            "distance_m": round(b.distance_m, 2)})
    scanner = {k: v for k, v in status.items() if k not in ("uuids",)}
    return {"duration_s": duration_s, "beacons": beacons, "scanner": scanner}


def _print_table(report: dict[str, Any]) -> None:
    print(f"{'MAC':17}  {'major':>5} {'minor':>5}  {'n':>4} {'Hz':>5}  {'RSSI':>6} "
          f"{'std':>5}  {'dist m':>6}  UUID")
    for b in report["beacons"]:
        print(f"{b['mac']:17}  {b['major']:>5} {b['minor']:>5}  {b['sightings']:>4} "
              f"{b['rate_hz']:>5}  {b['rssi_dbm']:>6} {b['rssi_std_db']:>5}  "
              f"{b['distance_m']:>6}  {b['uuid']}")
    s = report["scanner"]
    print(f"adverts {s['adverts']}, iBeacon sightings {s['sightings']}, not iBeacon "
          f"{s['not_ibeacon']}, other UUID {s['other_uuid']}, malformed {s['malformed']}, "
          f"no RSSI {s['bad_rssi']}, "
          f"restarts {s['restarts']}, errors {s['scan_errors']}")


def main(argv: list[str] | None = None) -> int:
    return run_standalone("robotd probe ble", __doc__, add_arguments, run, argv)


if __name__ == "__main__":
    sys.exit(main())
