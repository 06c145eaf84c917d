"""``robotd probe hx711``: read the load cell with the real driver, tare and calibrate it.

    robotd probe hx711                      # readings with the configured tare and factor
    robotd probe hx711 --tare               # zero it with the bin empty
    robotd probe hx711 --known-kg 2.0       # tare, then place 2 kg: prints the factor for TOML

GPIO numbers, gain and rate come from ``--config`` (section ``hx711``) or the options.
``--sim`` reads a simulated HX711 carrying ``--sim-kg`` instead of the GPIO lines.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import math
import statistics
import sys
from collections.abc import Callable
from typing import Any

from drivers.hx711 import Gain, Hx711
from hal.devices import DeviceUnavailable
from hal.ports import Hx711Lines
from robotd.config.errors import ConfigError
from robotd.config.loader import defaults, load_config
from robotd.probes import run_standalone, simulator


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--config", help="take the hx711 section from this robotd.toml")
    parser.add_argument("--chip", type=int, help="GPIO chip number (hx711.gpiochip)")
    parser.add_argument("--data-gpio", type=int, help="GPIO wired to DOUT")
    parser.add_argument("--clock-gpio", type=int, help="GPIO wired to PD_SCK")
    parser.add_argument("--gain", choices=[g.name for g in Gain], help="channel and gain")
    parser.add_argument("--sps", type=int, choices=(10, 80), help="rate the RATE pin selects")
    parser.add_argument("--readings", type=int, default=20, help="readings to average")
    parser.add_argument("--tare", action="store_true", help="zero with the bin empty first")
    parser.add_argument("--known-kg", type=float,
                        help="calibrate: tare, then place this mass; prints the factor")
    parser.add_argument("--wait-s", type=float,
                        help="seconds to wait instead of asking for Enter between steps")
    parser.add_argument("--sim", action="store_true", help="read a simulated HX711")
    parser.add_argument("--sim-kg", type=float, default=4.2, help="load on the simulated cell")
    if "--json" not in parser._option_string_actions:
        parser.add_argument("--json", action="store_true", help="print one JSON object")


def _settings(args: argparse.Namespace) -> dict[str, Any]:
    values = load_config(args.config)["hx711"] if args.config else defaults()["hx711"]
    for key, arg in (("gpiochip", "chip"), ("data_gpio", "data_gpio"),
                     ("clock_gpio", "clock_gpio"), ("gain", "gain"), ("sps", "sps")):
        if getattr(args, arg) is not None:
            values[key] = getattr(args, arg)
    return values


def _bad_option(args: argparse.Namespace) -> str | None:
    """Why the numeric options cannot be used, or None."""
    if args.known_kg is not None and not (args.known_kg > 0 and math.isfinite(args.known_kg)):
        return f"--known-kg: expected the calibration mass in kg (> 0), got {args.known_kg}"
    if not (args.sim_kg >= 0 and math.isfinite(args.sim_kg)):
        return f"--sim-kg: expected a load in kg (>= 0), got {args.sim_kg}"
    if args.readings < 1:
        return f"--readings: expected at least 1, got {args.readings}"
    if args.wait_s is not None and not (args.wait_s >= 0 and math.isfinite(args.wait_s)):
        return f"--wait-s: expected seconds (>= 0), got {args.wait_s}"
    return None


async def run(args: argparse.Namespace) -> int:
    problem = _bad_option(args)
    if problem:
        print(f"probe hx711: {problem}", file=sys.stderr)
        return 2
    try:
        cfg = _settings(args)
    except ConfigError as exc:
        print(f"probe hx711: {exc}", file=sys.stderr)
        return 2
    calibrating = args.known_kg is not None
    load = {"kg": 0.0 if calibrating or args.tare else args.sim_kg}
    open_lines: Callable[[], Hx711Lines]
    if args.sim:
        sim = simulator().hx711_lines(lambda: load["kg"], cfg["sps"])
        open_lines = lambda: sim  # noqa: E731
    else:
        from drivers.gpio_lgpio import lgpio_lines_opener

        open_lines = lgpio_lines_opener(cfg["gpiochip"], cfg["data_gpio"], cfg["clock_gpio"])
    hx = Hx711(open_lines, gain=Gain[cfg["gain"]], sps=cfg["sps"],
               tare_offset=cfg["tare_offset"], calibration_factor=cfg["calibration_factor"],
               average_window=cfg["average_window"], median_window=cfg["median_window"],
               outlier_kg=cfg["outlier_kg"], timeout_s=cfg["timeout_s"])
    try:
        await hx.start()
    except DeviceUnavailable as exc:
        print(f"probe hx711: {exc}", file=sys.stderr)
        return 1
    report: dict[str, Any] = {}
    try:
        if args.tare or calibrating:
            await _step(args, "Empty the bin, then press Enter", quiet=args.json)
            await hx.tare()
            report["tare_offset"] = hx.tare_offset
        if calibrating:
            await _step(args, f"Place {args.known_kg:g} kg on the cell, then press Enter",
                        quiet=args.json)
            load["kg"] = args.known_kg  # the simulated technician places it
            report["calibration_factor"] = round(await hx.calibrate(args.known_kg), 3)
        report.update(await _measure(hx, args.readings))
    except (ValueError, DeviceUnavailable) as exc:
        print(f"probe hx711: {exc}", file=sys.stderr)
        return 1
    finally:
        await hx.close()
    if args.json:
        print(json.dumps(report))
    else:
        _print(report, args)
    return 0


async def _step(args: argparse.Namespace, prompt: str, *, quiet: bool) -> None:
    if args.sim:
        return
    if args.wait_s is not None:
        if not quiet:
            print(f"{prompt.split(',', maxsplit=1)[0]} ({args.wait_s:g} s)...", file=sys.stderr)
        await asyncio.sleep(args.wait_s)
        return
    print(prompt, file=sys.stderr)
    await asyncio.get_running_loop().run_in_executor(None, sys.stdin.readline)


async def _measure(hx: Hx711, count: int) -> dict[str, Any]:
    """``count`` readings; DeviceUnavailable when they stop coming (every read discarded)."""
    loop = asyncio.get_running_loop()
    t0 = loop.time()
    wait_s = hx.timeout_s + 10 * hx.period_s
    readings = []
    for _ in range(max(1, count)):
        try:
            readings.append(await asyncio.wait_for(hx.next_reading(), wait_s))
        except TimeoutError:
            c = hx.counts
            msg = (f"{hx.name}: no good reading for {wait_s:g} s: reads {c['reads']}, "
                   f"saturated {c['saturated']} (input out of range: a loose or shorted "
                   f"bridge wire?), long clock pulse {c['sck_high']}, outliers "
                   f"{c['outliers']}, data-ready timeouts {c['timeouts']}, GPIO errors "
                   f"{c['line_errors']}")
            raise DeviceUnavailable(msg) from None
    elapsed_s = loop.time() - t0
    kgs = [r.kg for r in readings]
    return {
        "kg": round(statistics.fmean(kgs), 4),
        "kg_std": round(statistics.pstdev(kgs), 4),
        "raw": readings[-1].raw,
        "readings": len(readings),
        "rate_hz": round(len(readings) / elapsed_s, 2) if elapsed_s > 0 else None,
        "tare_offset": hx.tare_offset,
        "calibration_factor": round(hx.calibration_factor, 3),
        "counts": dict(hx.counts),
    }


def _print(report: dict[str, Any], args: argparse.Namespace) -> None:
    print(f"weight {report['kg']:.3f} kg (std {report['kg_std']:.4f} kg over "
          f"{report['readings']} readings, {report['rate_hz']} Hz), raw {report['raw']}")
    c = report["counts"]
    print(f"reads {c['reads']}, discarded: long clock pulse {c['sck_high']}, saturated "
          f"{c['saturated']}, outliers {c['outliers']}, data-ready timeouts {c['timeouts']}")
    if args.tare or args.known_kg is not None:
        print("\nPut this in robotd.toml:\n[hx711]")
        print(f"tare_offset = {report['tare_offset']}")
        print(f"calibration_factor = {report['calibration_factor']}")


def main(argv: list[str] | None = None) -> int:
    return run_standalone("robotd probe hx711", __doc__, add_arguments, run, argv)


if __name__ == "__main__":
    sys.exit(main())
