"""``robotd probe serial``: check the motor board link with the real driver.

    robotd probe serial --port /dev/ttyACM0                  # handshake and 20 heartbeats
    robotd probe serial --port P --send LED_IDLE --count 500 --rate 100 --json

Opens the port, does the HELLO handshake, sends the command ``--count`` times at ``--rate``
per second (each waits for its acknowledgement; a late one makes the next go at once) and
prints acked/resent/lost and the round-trip times. Exit 0 when every command was
acknowledged, 1 otherwise.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import sys
from typing import Any

from drivers.arduino import ArduinoLink, Delivery, Framing, LinkConfig, Outcome
from drivers.arduino.framing import encode_command
from drivers.arduino.stats import percentile
from drivers.serial_port import open_serial
from hal.devices import DeviceUnavailable
from robotd.config.errors import ConfigError
from robotd.config.loader import defaults, load_config
from robotd.config.settings import Settings
from robotd.probes.serial_tap import ReceivedTap


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--config", help="take the serial section from this robotd.toml")
    parser.add_argument("--port", help="serial device (serial.port)")
    parser.add_argument("--baud", type=int, help="baud rate (serial.baud)")
    parser.add_argument("--framing", choices=[f.value for f in Framing],
                        help="crc or plain (serial.framing)")
    parser.add_argument("--send", default="HB", metavar="CMD",
                        help="command payload to send, e.g. HB, LED_IDLE, SERVO:90 (default HB)")
    parser.add_argument("--count", type=int, default=20, help="how many times (default 20)")
    parser.add_argument("--rate", type=float, default=10.0, metavar="HZ",
                        help="commands per second; 0: back to back (default 10)")
    if "--json" not in parser._option_string_actions:
        parser.add_argument("--json", action="store_true", help="print one JSON object")


def _config(args: argparse.Namespace) -> LinkConfig:
    values = load_config(args.config) if args.config else defaults()
    for key in ("port", "baud", "framing"):
        if getattr(args, key) is not None:
            values["serial"][key] = getattr(args, key)
    return LinkConfig.from_settings(Settings(values))


async def run(args: argparse.Namespace) -> int:
    try:
        config = _config(args)
        encode_command(args.send, 0, config.framing)
    except (ConfigError, ValueError) as exc:
        print(f"probe serial: {exc}", file=sys.stderr)
        return 2
    if args.count < 1 or args.rate < 0:
        print("probe serial: --count must be >= 1 and --rate >= 0", file=sys.stderr)
        return 2
    tap = ReceivedTap(open_serial)
    link = ArduinoLink(tap.open, config, name="probe")
    try:
        await link.start()
    except DeviceUnavailable as exc:
        why = str(exc).rstrip().rstrip(":")
        if tap.opened:  # the port opened: say what (if anything) the board said
            why = f"{why}; {tap.summary()}"
        print(f"probe serial: {why}", file=sys.stderr)
        return 1
    try:
        report = await exercise(link, args.send, args.count, args.rate)
    finally:
        await link.close()
    if args.json:
        print(json.dumps(report))
    else:
        _print(report)
    return 0 if report["acked"] == args.count else 1


async def exercise(link: ArduinoLink, payload: str, count: int, rate_hz: float) -> dict[str, Any]:
    """Send ``payload`` ``count`` times at ``rate_hz``, each awaited; the figures as a dict."""
    loop = asyncio.get_running_loop()
    period_s = 1.0 / rate_hz if rate_hz > 0 else 0.0
    start_s = loop.time()
    deliveries: list[Delivery] = []
    for i in range(count):
        wait_s = start_s + i * period_s - loop.time()
        if wait_s > 0:
            await asyncio.sleep(wait_s)
        if not link.connected and not await link.wait_connected(link.config.handshake_timeout_s):
            break
        deliveries.append(await link.command(payload))
    elapsed_s = loop.time() - start_s
    rtts = [d.rtt_s for d in deliveries if d.rtt_s is not None]
    outcomes = [d.outcome for d in deliveries]
    p50, p99 = percentile(rtts, 0.5), percentile(rtts, 0.99)
    stats = link.link_stats()
    return {
        "port": link.config.port, "framing": link.config.framing.value,
        "firmware": link.firmware, "protocol": link.protocol, "command": payload,
        "count": count, "sent": len(deliveries),
        "acked": outcomes.count(Outcome.ACKED),
        "resent": sum(d.resends for d in deliveries),
        "lost": outcomes.count(Outcome.LOST),
        "nak": outcomes.count(Outcome.NAK),
        "link_down": outcomes.count(Outcome.LINK_DOWN) + count - len(deliveries),
        "rtt_p50_ms": None if p50 is None else round(p50 * 1000, 3),
        "rtt_p99_ms": None if p99 is None else round(p99 * 1000, 3),
        "duration_s": round(elapsed_s, 3),
        "rate_hz": round(len(deliveries) / elapsed_s, 2) if elapsed_s > 0 else None,
        "crc_errors": stats.crc_errors, "reconnects": stats.reconnects,
    }


def _ms(value: float | None) -> str:
    return "-" if value is None else f"{value:.2f} ms"


def _print(r: dict[str, Any]) -> None:
    print(f"{r['port']}: firmware {r['firmware']} (protocol {r['protocol']}), "
          f"framing {r['framing']}")
    print(f"{r['command']} x{r['count']} in {r['duration_s']} s ({r['rate_hz']}/s): "
          f"acked {r['acked']}, resent {r['resent']}, lost {r['lost']}, nak {r['nak']}, "
          f"link down {r['link_down']}")
    print(f"RTT p50 {_ms(r['rtt_p50_ms'])}, p99 {_ms(r['rtt_p99_ms'])} (first tries); "
          f"line errors seen {r['crc_errors']}, reconnects {r['reconnects']}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="robotd probe serial", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    add_arguments(parser)
    from robotd.logs import configure_logging

    configure_logging("warning")
    return asyncio.run(run(parser.parse_args(argv)))


if __name__ == "__main__":
    sys.exit(main())
