"""``robotctl``: look at and steer a running robotd through its control socket.

Exit codes: 0 ok, 1 the daemon answered with an error, 2 usage, 3 cannot connect.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from typing import Any

from behaviours.profile import CtlCommand
from robotd.ctl.connection import (
    DEFAULT_SOCKET,
    EXIT_CONNECT,
    EXIT_ERROR,
    EXIT_OK,
    CannotConnect,
    Connection,
    DaemonError,
    call_estop,
)

__all__ = ["DEFAULT_SOCKET", "CannotConnect", "Connection", "DaemonError", "main", "render"]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="robotctl", description="Steer a running robotd.")
    parser.add_argument("--socket", default=os.environ.get("ROBOTD_SOCKET", DEFAULT_SOCKET),
                        help=f"control socket (default $ROBOTD_SOCKET or {DEFAULT_SOCKET})")
    parser.add_argument("--json", action="store_true", help="print JSON instead of tables")
    parser.add_argument("--timeout", type=float, default=5.0, help="seconds to wait for answers")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    sub.add_parser("status", help="state, estop, uptime, services, loop lag")
    sub.add_parser("sensors", help="each device's figures (link statistics ...)")
    events = sub.add_parser("events", help="recent events")
    events.add_argument("--limit", type=int, default=20)
    events.add_argument("--kind", help="only events of this kind (transition, service ...)")
    watch_p = sub.add_parser("watch", help="a live view that fits the terminal, redrawn on "
                             "every state change (Ctrl-C ends)")
    watch_p.add_argument("--interval", type=float, default=1.0,
                         help="seconds between sensor refreshes")
    tune = sub.add_parser("tune", help="read or set a setting live")
    tune_sub = tune.add_subparsers(dest="tune_command", required=True, metavar="get|set")
    get = tune_sub.add_parser("get", help="tune get KEY")
    get.add_argument("key", metavar="KEY", help="section.key, e.g. line_follow.kp")
    tset = tune_sub.add_parser("set", help="tune set KEY VALUE [--persist]")
    tset.add_argument("key", metavar="KEY")
    tset.add_argument("value", metavar="VALUE")
    tset.add_argument("--persist", action="store_true",
                      help="also keep it across restarts (overrides file in the state dir)")
    sub.add_parser("reload", help="read the config file again (kept if the new one is bad)")
    estop = sub.add_parser("estop", help="emergency stop: motors stopped, state estop")
    estop.add_argument("--reason", default="robotctl estop")
    sub.add_parser("resume", help="leave estop for idle")
    trigger = sub.add_parser("trigger", help="fire a state machine trigger (e.g. go_dock)")
    trigger.add_argument("name", metavar="NAME")
    pose = sub.add_parser("pose", help="a navigating robot's pose on its map")
    pose_sub = pose.add_subparsers(dest="pose_command", required=True, metavar="set")
    pset = pose_sub.add_parser("set", help="pose set X Y THETA: where the robot is (metres and "
                               "degrees, map frame); its localisation starts again from there")
    pset.add_argument("x", metavar="X", type=float, help="x in the map frame (m)")
    pset.add_argument("y", metavar="Y", type=float, help="y in the map frame (m)")
    pset.add_argument("theta", metavar="THETA", type=float,
                      help="heading, degrees counter-clockwise from +x")
    pset.add_argument("--sigma", type=float, default=None,
                      help="how far off the position may be (m; default 0.25)")
    pset.add_argument("--sigma-deg", type=float, default=None,
                      help="how far off the heading may be (degrees; default 10)")
    drive = sub.add_parser("drive", help="drive the robot by hand (idle, maintenance or robotd "
                           "map only); it stops 0.5 s after the last command")
    drive.add_argument("--linear", type=float, default=0.0, help="m/s, forward positive")
    drive.add_argument("--angular", type=float, default=0.0,
                       help="rad/s, counter-clockwise positive")
    drive.add_argument("--for", dest="for_s", type=float, default=None, metavar="S",
                       help="keep driving S seconds (refreshed), then stop")
    drive.add_argument("--keys", action="store_true", help="drive with the keyboard")
    map_p = sub.add_parser("map", help="the map robotd map is making")
    map_sub = map_p.add_subparsers(dest="map_command", required=True, metavar="save")
    msave = map_sub.add_parser("save", help="map save NAME: NAME.pgm + NAME.yaml into the "
                               "robot's maps directory")
    msave.add_argument("name", metavar="NAME")
    for command in profile_commands().values():
        own = sub.add_parser(command.name, help=command.help)
        for option in command.options:
            own.add_argument(option.flag, default=option.default, help=option.help)
    _json_after_commands(parser)
    return parser


def _json_after_commands(parser: argparse.ArgumentParser) -> None:
    """``--json`` after the command too (``robotctl status --json``), as before it. Its
    default is left unset there, so a ``--json`` given before the command still counts."""
    for action in parser._actions:
        if not isinstance(action, argparse._SubParsersAction):
            continue
        for command in action.choices.values():
            if "--json" not in command._option_string_actions:
                command.add_argument("--json", action="store_true", default=argparse.SUPPRESS,
                                     help="print JSON instead of tables")
            _json_after_commands(command)


def profile_commands() -> dict[str, CtlCommand]:
    """The commands the registered profiles add, by name."""
    from robotd.profiles import PROFILES

    return {c.name: c for spec in PROFILES.specs() for c in spec.commands}


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.command == "estop":
        return _estop(args)
    try:
        conn = Connection(args.socket, args.timeout)
    except CannotConnect as exc:
        print(f"robotctl: {exc}", file=sys.stderr)
        return EXIT_CONNECT
    try:
        if args.command == "watch":
            from robotd.ctl.watch import watch

            return watch(conn, args.interval, sys.stdout)
        if args.command == "drive":
            from robotd.ctl.drive import drive_for, drive_keys

            if args.keys:
                return drive_keys(conn, sys.stdout)
            result = drive_for(conn, args.linear, args.angular, args.for_s)
            print(json.dumps(result, indent=2) if args.json else render("drive", result),
                  end="\n" if args.json else "")
            return EXIT_OK
        method, params = _request(args)
        if args.command in ("pose", "map"):  # the method is the running profile's own
            method = f"{conn.call('status', {}).get('profile')}.{method}"
        result = conn.call(method, params)
        if args.json:
            print(json.dumps(result, indent=2, default=str))
        else:
            print(render(args.command, result), end="")
        return EXIT_OK
    except DaemonError as exc:
        _print_error(exc, args.json)
        return EXIT_ERROR
    except CannotConnect as exc:
        print(f"robotctl: {exc}", file=sys.stderr)
        return EXIT_CONNECT
    except KeyboardInterrupt:
        return EXIT_OK
    except BrokenPipeError:  # robotctl watch | head: the reader left
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_OK
    finally:
        conn.close()


def _estop(args: argparse.Namespace) -> int:
    """``robotctl estop``: through the control socket, or the e-stop socket beside it."""
    try:
        result = call_estop(args.socket, args.timeout, {"reason": args.reason})
    except DaemonError as exc:
        _print_error(exc, args.json)
        return EXIT_ERROR
    except CannotConnect as exc:
        print(f"robotctl: {exc}", file=sys.stderr)
        return EXIT_CONNECT
    if args.json:
        print(json.dumps(result, indent=2, default=str))
    else:
        print(render("estop", result), end="")
    return EXIT_OK


def _request(args: argparse.Namespace) -> tuple[str, dict[str, Any]]:
    if args.command == "events":
        params: dict[str, Any] = {"limit": args.limit}
        if args.kind:
            params["kind"] = args.kind
        return "events", params
    if args.command == "tune":
        if args.tune_command == "get":
            return "tune.get", {"key": args.key}
        return "tune.set", {"key": args.key, "value": args.value, "persist": args.persist}
    if args.command == "estop":
        return "estop", {"reason": args.reason}
    if args.command == "trigger":
        return "trigger", {"name": args.name}
    if args.command == "pose":
        params = {"x_m": args.x, "y_m": args.y, "heading_deg": args.theta}
        if args.sigma is not None:
            params["sigma_m"] = args.sigma
        if args.sigma_deg is not None:
            params["sigma_deg"] = args.sigma_deg
        return "set_pose", params
    if args.command == "map":
        return "save_map", {"name": args.name}
    own = profile_commands().get(args.command)
    if own is not None:
        return own.method, {o.param: getattr(args, o.param) for o in own.options}
    return args.command, {}


def _print_error(exc: DaemonError, as_json: bool) -> None:
    if as_json:
        print(json.dumps({"error": exc.error}, indent=2))
        return
    print(f"robotctl: robotd refused: {exc.error.get('message')}", file=sys.stderr)
    data = exc.error.get("data")
    if isinstance(data, dict):
        for problem in data.get("problems", []):
            print(f"  {problem}", file=sys.stderr)


def render(command: str, result: Any) -> str:
    """Readable text for a command's result."""
    if command == "status":
        return _render_status(result)
    if command == "sensors":
        return _render_sensors(result)
    own = profile_commands().get(command)
    if own is not None and own.render is not None:
        return own.render(result, table)
    if command == "events":
        rows = [[f"{e.get('t', 0):.3f}", str(e.get("kind", "")),
                 " ".join(f"{k}={_short(v)}" for k, v in e.items() if k not in ("t", "kind"))]
                for e in result]
        return table(["t_s", "kind", "details"], rows) if rows else "no events\n"
    if command == "tune":
        suffix = ""
        if result.get("persisted"):
            suffix = f" (persisted in {result['persisted_to']})" if "persisted_to" in result \
                else " (persisted)"
        note = f"note: {result['note']}\n" if result.get("note") else ""
        return f"{result['key']} = {json.dumps(result['value'])}{suffix}\n{note}"
    if isinstance(result, dict):
        return table(["key", "value"], [[k, _short(v)] for k, v in result.items()])
    return f"{result}\n"


def _estop_text(s: dict[str, Any]) -> str:
    """``YES (latched: robotctl, "reason", at ...)`` while latched; why it is on, and since."""
    latch = s.get("estop_latch")
    if not s.get("estop"):
        return "no"
    if not isinstance(latch, dict):
        return "YES"
    return f"YES (latched: {latch.get('source')}, {latch.get('reason')!r}, at {latch.get('at')})"


def _fault_text(fault: Any) -> str:
    """``line_lost: no line for 13 frames`` while in recovery, ``-`` otherwise."""
    if not isinstance(fault, dict):
        return "-"
    return f"{fault.get('code')}: {fault.get('message')}".rstrip(": ")


def _render_status(s: dict[str, Any]) -> str:
    lag = s.get("loop_lag_ms", {})
    head: list[list[Any]] = [
        ["robot", s.get("robot")], ["profile", s.get("profile")], ["state", s.get("state")],
        ["estop", _estop_text(s)], ["fault", _fault_text(s.get("fault"))],
        ["uptime", f"{s.get('uptime_s', 0):.1f} s"],
        ["link", s.get("link") or "-"],
        ["loop lag", f"p50 {lag.get('p50_ms', 0):.2f} ms, p99 {lag.get('p99_ms', 0):.2f} ms, "
                     f"max {lag.get('max_ms', 0):.2f} ms"],
        ["triggers", ", ".join(s.get("triggers", []))], ["config", s.get("config")],
    ]
    head += [[f"mission.{k}", "-" if v is None else _short(v)]
             for k, v in (s.get("mission") or {}).items()]
    services = [[v["name"], v["state"], "yes" if v["critical"] else "no", v["restarts"],
                 v.get("last_error") or ""] for v in s.get("services", [])]
    return (table(["key", "value"], head) + "\n"
            + table(["service", "state", "critical", "restarts", "last error"], services))


def _render_sensors(result: dict[str, Any]) -> str:
    rows: list[list[Any]] = []
    for device, figures in result.get("devices", {}).items():
        for key, value in figures.items():
            if isinstance(value, dict):
                rows += [[device, f"{key}.{k}", _short(v)] for k, v in value.items()]
            else:
                rows.append([device, key, _short(value)])
    return table(["device", "figure", "value"], rows) if rows else "no devices\n"


def table(headers: list[str], rows: list[list[Any]]) -> str:
    cells = [[str(c) for c in row] for row in rows]
    widths = [max(len(h), *(len(r[i]) for r in cells)) if cells else len(h)
              for i, h in enumerate(headers)]
    lines = ["  ".join(h.upper().ljust(w) for h, w in zip(headers, widths, strict=True))]
    lines += ["  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)) for r in cells]
    return "\n".join(line.rstrip() for line in lines) + "\n"


def _short(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.4g}"
    if isinstance(value, dict | list):
        return json.dumps(value, default=str)
    return str(value)

