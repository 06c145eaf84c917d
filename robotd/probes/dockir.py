"""``robotd probe dockir``: what the dock IR receivers decode, live or from a recorded capture.

    robotd probe dockir [--seconds 5] [--json]     # the receivers on their GPIO lines
    robotd probe dockir --replay FILE.ir [--json]  # a Flipper Zero capture instead

Live: codes per receiver per second and the decode error rate, through the real driver (GPIO
lines, polarity, tolerance and codes from ``--config``, section ``docking``). Replay: each
``type: raw`` signal of a Flipper ``.ir`` file through the same decoder; prints every code
found with its count and the error counters. A malformed file: ``FILE:LINE: message``, exit 2.
"""

from __future__ import annotations

import argparse
import asyncio
import collections
import json
import math
import sys
from typing import Any

from drivers.dock_ir.config import DockIrConfig
from drivers.dock_ir.edge_decoder import EdgeDecoder
from drivers.dock_ir.flipper import FlipperFormatError, read_ir_file, signal_edges
from drivers.dock_ir.receivers import DockIrReceivers
from drivers.dock_ir.stats import DecodeStats, total
from hal.devices import DeviceUnavailable
from robotd.config.errors import ConfigError
from robotd.config.loader import defaults, load_config
from robotd.config.settings import Settings
from robotd.probes import run_standalone

REPLAY_RECEIVER = "replay"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--config", help="take the docking section from this robotd.toml")
    parser.add_argument("--chip", type=int, help="GPIO chip number (docking.ir_gpiochip)")
    parser.add_argument("--seconds", type=float, default=5.0, help="how long to listen")
    parser.add_argument("--replay", metavar="FILE",
                        help="decode a Flipper Zero .ir capture instead of the GPIO lines")
    if "--json" not in parser._option_string_actions:
        parser.add_argument("--json", action="store_true", help="print one JSON object")


def _settings(args: argparse.Namespace) -> Settings:
    values = load_config(args.config) if args.config else defaults()
    if args.chip is not None:
        values["docking"]["ir_gpiochip"] = args.chip
    return Settings(values)


async def run(args: argparse.Namespace) -> int:
    if not (args.seconds > 0 and math.isfinite(args.seconds)):
        print(f"probe dockir: --seconds: expected a time > 0, got {args.seconds}",
              file=sys.stderr)
        return 2
    try:
        cfg = DockIrConfig.from_settings(_settings(args))
    except (ConfigError, ValueError) as exc:
        print(f"probe dockir: {exc}", file=sys.stderr)
        return 2
    if args.replay:
        return replay(args.replay, cfg, as_json=args.json)
    return await _listen(args, cfg)


# --- replay ---------------------------------------------------------------------------------
def replay(path: str, cfg: DockIrConfig, *, as_json: bool) -> int:
    try:
        capture = read_ir_file(path)
    except FlipperFormatError as exc:
        print(str(exc), file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"{path}:1: cannot read: {exc.strerror or exc}", file=sys.stderr)
        return 2
    stats = DecodeStats()
    counts: collections.Counter[int] = collections.Counter()
    signals = []
    for signal in capture.signals:
        found = decode_durations(signal.durations_us, cfg, stats)
        counts.update(found)
        signals.append({"name": signal.name, "line": signal.line, "codes": found})
    report = {
        "file": path,
        "signals": len(capture.signals),
        "skipped": capture.notes,
        "codes": [{"code": code, "name": cfg.table.describe(code), "count": n}
                  for code, n in sorted(counts.items())],
        "by_signal": signals,
        "counters": stats.as_dict(),
    }
    if as_json:
        print(json.dumps(report))
    else:
        _print_replay(report)
    return 0


def decode_durations(durations_us: tuple[int, ...], cfg: DockIrConfig,
                     stats: DecodeStats) -> list[int]:
    """The codes in one capture, in order; damage and unknown codes counted in ``stats``."""
    decoder = EdgeDecoder(active_low=cfg.active_low, tolerance=cfg.tolerance, stats=stats)
    edges = signal_edges(durations_us, receiver=REPLAY_RECEIVER, active_low=cfg.active_low)
    found = []
    for edge in edges:
        code = decoder.feed(edge.level, edge.t_us)
        if code is not None:
            found.append(code)
    code = decoder.flush(edges[-1].t_us + decoder.gap_us + 1)  # the capture ends quiet
    if code is not None:
        found.append(code)
    stats.unknown_codes += sum(1 for c in found if not cfg.table.known(c))
    return found


def _print_replay(report: dict[str, Any]) -> None:
    print(f"{report['file']}: {report['signals']} raw signal(s)")
    for note in report["skipped"]:
        print(f"  note: {note}")
    for signal in report["by_signal"]:
        codes = ", ".join(map(str, signal["codes"])) or "no code"
        print(f"  {signal['name']} (line {signal['line']}): {codes}")
    print("codes:" if report["codes"] else "codes: none decoded")
    for entry in report["codes"]:
        print(f"  {entry['code']:3d}  x{entry['count']:<4d} {entry['name']}")
    _print_counters(report["counters"])


def _print_counters(c: dict[str, Any]) -> None:
    rate = "n/a" if c["error_rate"] is None else f"{100 * c['error_rate']:.1f} %"
    print(f"errors: glitches {c['glitches']}, half codes {c['half_codes']}, collisions "
          f"{c['collisions']}, dropped edges {c['dropped_edges']}; unknown codes "
          f"{c['unknown_codes']}; error rate {rate}")


# --- live -----------------------------------------------------------------------------------
async def _listen(args: argparse.Namespace, cfg: DockIrConfig) -> int:
    from drivers.dock_ir.gpio_edges import lgpio_edges_opener

    device = DockIrReceivers(lgpio_edges_opener(cfg.gpiochip, cfg.lines),
                             receivers=tuple(cfg.lines), table=cfg.table,
                             window_s=cfg.window_s, active_low=cfg.active_low,
                             tolerance=cfg.tolerance)
    counts: dict[str, collections.Counter[int]] = {r: collections.Counter() for r in cfg.lines}
    device.on_code(lambda receiver, code, _t: counts[receiver].update((code,)))
    try:
        await device.start()
    except DeviceUnavailable as exc:
        print(f"probe dockir: {exc}", file=sys.stderr)
        return 1
    try:
        await asyncio.sleep(args.seconds)
    finally:
        await device.close()
    report = live_report(device, counts, args.seconds, cfg.lines)
    if args.json:
        print(json.dumps(report))
    else:
        _print_live(report)
    return 0


def live_report(device: DockIrReceivers, counts: dict[str, collections.Counter[int]],
                seconds: float, lines: dict[str, int]) -> dict[str, Any]:
    receivers = {
        r: {"gpio": lines[r],
            "codes_per_s": {str(c): round(n / seconds, 2) for c, n in sorted(counts[r].items())},
            "counters": device.stats[r].as_dict()}
        for r in counts
    }
    return {"seconds": seconds, "receivers": receivers,
            "names": {str(c): device.table.describe(c)
                      for cs in counts.values() for c in cs},
            "total": total(list(device.stats.values())).as_dict()}


def _print_live(report: dict[str, Any]) -> None:
    print(f"listened {report['seconds']:g} s")
    for receiver, r in report["receivers"].items():
        codes = ", ".join(f"{c} ({report['names'][c]}) {n}/s"
                          for c, n in r["codes_per_s"].items()) or "nothing"
        print(f"  {receiver:<12} GPIO {r['gpio']:<3} {codes}")
    _print_counters(report["total"])


def main(argv: list[str] | None = None) -> int:
    return run_standalone("robotd probe dockir", __doc__, add_arguments, run, argv)


if __name__ == "__main__":
    sys.exit(main())
