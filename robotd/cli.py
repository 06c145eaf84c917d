"""``robotd``: run the service, run the simulator, check a config file, map a log, probe a
device."""

from __future__ import annotations

import argparse
import asyncio
import importlib
import os
import sqlite3
import sys
from pathlib import Path

from robotd import __version__, bundle, update
from robotd.config import ConfigError, Settings, load_config
from robotd.config.overrides import overrides_path
from robotd.extensions import simulator_part
from robotd.probes import PROBES
from robotd.profiles import PROFILES

DEFAULT_CONFIG = "/etc/robotd/robotd.toml"


def build_parser(argv: list[str] | None = None) -> argparse.ArgumentParser:
    """The command line; the simulator's own arguments are read only when ``argv`` (default
    ``sys.argv[1:]``) asks for ``sim`` or for help: ``robotd run`` does not load it."""
    argv = sys.argv[1:] if argv is None else argv
    parser = argparse.ArgumentParser(prog="robotd", description="An asyncio robot runtime.")
    parser.add_argument("--version", action="version", version=f"robotd {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    run = sub.add_parser("run", help="run the robot (real hardware); the systemd service")
    run.add_argument("--config", help=f"config file (default $ROBOTD_CONFIG or {DEFAULT_CONFIG})")

    wants_sim = not argv or argv[0] in ("sim", "-h", "--help")
    simulator = simulator_part("command") if wants_sim else None
    if simulator is not None:  # the simulator plugs `robotd sim` in (robotd/extensions.py)
        simulator.add_arguments(sub.add_parser("sim", help=simulator.HELP))

    check = sub.add_parser("check-config", help="check a config file; one line per problem")
    check.add_argument("path", metavar="PATH")
    sub.add_parser("example-config", help="print a commented config with every key")

    update.add_arguments(sub.add_parser("update", help=update.HELP))
    bundle.add_arguments(sub.add_parser("bundle", help=bundle.HELP))

    from robotd.mapping import command as map_command

    map_command.add_arguments(sub.add_parser("map", help=map_command.HELP))

    probe = sub.add_parser("probe", help="check one real device through its driver",
                           description="Devices: " + "; ".join(
                               f"{name}: {what}" for name, (_, what) in PROBES.items()))
    probe.add_argument("device", choices=sorted(PROBES), metavar="DEVICE",
                       help=", ".join(sorted(PROBES)))
    probe.add_argument("options", nargs=argparse.REMAINDER,
                       help="the device's options (robotd probe DEVICE --help)")
    return parser


def main(argv: list[str] | None = None) -> int:
    try:
        return _main(argv)
    except BrokenPipeError:
        # A reader that stopped early (`robotd sim | head`): the rest of the output has
        # nowhere to go. Point stdout at /dev/null so the interpreter's final flush is quiet.
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 1


def _main(argv: list[str] | None) -> int:
    args = build_parser(argv).parse_args(argv)
    if args.command == "run":
        return cmd_run(args)
    if args.command == "sim":
        return cmd_sim(args)
    if args.command == "check-config":
        return cmd_check_config(args)
    if args.command in ("update", "bundle"):
        return int(update.run(args) if args.command == "update" else bundle.run(args))
    if args.command == "map":
        from robotd.mapping import command as map_command

        if args.from_log is None:  # live: the daemon, on the robot's drivers, mapping
            from robotd.profiles import MAPPING_PROFILE

            return cmd_run(args, profile=MAPPING_PROFILE)
        return map_command.run(args)
    if args.command == "example-config":
        from robotd.config.example import render_example

        print(render_example(), end="")
        return 0
    return cmd_probe(args)


def cmd_check_config(args: argparse.Namespace) -> int:
    try:
        load_config(args.path)
    except ConfigError as exc:
        for problem in exc.problems:
            print(problem)
        return 2
    print(f"{args.path}: ok")
    return 0


def cmd_sim(args: argparse.Namespace) -> int:
    simulator = simulator_part("command")
    if simulator is None:  # build_parser offered no `sim`: not reached
        print("robotd sim: the simulator is not installed", file=sys.stderr)
        return 1
    code: int = simulator.run(args)
    return code


def cmd_probe(args: argparse.Namespace) -> int:
    module_name, what = PROBES[args.device]
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        print(f"robotd probe: no probe for {args.device!r} in this installation "
              f"({module_name}: {exc})", file=sys.stderr)
        return 2
    parser = argparse.ArgumentParser(prog=f"robotd probe {args.device}", description=what)
    module.add_arguments(parser)
    if not any("--json" in action.option_strings for action in parser._actions):
        parser.add_argument("--json", action="store_true", help="print one JSON object")
    options = parser.parse_args(args.options)
    from robotd.logs import configure_logging
    from robotd.probes import run_probe

    configure_logging("warning")
    return run_probe(module.run, options)


def cmd_run(args: argparse.Namespace, profile: str | None = None) -> int:
    """``robotd run``; ``profile``: run this profile instead of ``robot.profile`` (``robotd map``
    runs the survey on the robot's own config)."""
    from hal.ports import system_wall_clock
    from robotd.config.loader import load_config_and_overrides
    from robotd.control.access import socket_problem
    from robotd.daemon import Daemon
    from robotd.hardware import HardwareMissing, build_devices
    from robotd.logs import configure_logging
    from robotd.step_cpu import StepCpu
    from robotd.viz.runtime import open_daemon_viz, run_daemon, telemetry_of

    config_path = Path(args.config or os.environ.get("ROBOTD_CONFIG") or DEFAULT_CONFIG)
    try:
        values = load_config(config_path)
        state_dir = _state_dir(values["robot"]["state_dir"])
        values, ignored = load_config_and_overrides(config_path, overrides_path(state_dir))
    except ConfigError as exc:
        for problem in exc.problems:
            print(problem, file=sys.stderr)
        return 2
    for problem in ignored:  # tuning kept from before: not worth a robot that does not start
        print(f"{problem} (overrides file ignored; the robot runs on {config_path})",
              file=sys.stderr)
    if profile is not None:
        values["robot"]["profile"] = profile
    settings = Settings(values, source=str(config_path))
    configure_logging(settings.get("logging.level"))
    try:
        step_cpu = StepCpu.from_env()  # debug: the loop's long steps by CPU time
    except ValueError as exc:
        print(f"robotd: {exc}", file=sys.stderr)
        return 2
    if settings.get("hal.backend") == "sim":
        print(f"{config_path}: hal.backend is 'sim': use `robotd sim` for the simulator",
              file=sys.stderr)
        return 2
    socket_why = socket_problem(settings.get("control.socket"))
    if socket_why is not None:  # exit 2: restarting cannot fix it, and no robot runs deaf
        print(f"{config_path}: control.socket: {socket_why}", file=sys.stderr)
        return 2
    try:
        robot = PROFILES.build(settings.get("robot.profile"))
    except ValueError as exc:
        print(f"{config_path}: {exc}", file=sys.stderr)
        return 2
    try:
        devices = build_devices(settings, robot.devices)
    except HardwareMissing as exc:
        for missing in exc.problems:
            print(f"robotd: missing device: {missing}", file=sys.stderr)
        return 1
    viz = open_daemon_viz(settings, state_dir, system_wall_clock)  # None while [viz] is off
    try:
        daemon = Daemon(settings, devices, robot, state_dir=state_dir,
                        socket_path=settings.get("control.socket"),
                        wall_clock=system_wall_clock, config_path=config_path, freeze_gc=True,
                        telemetry=telemetry_of(viz, settings.get("robot.name")))
    except (OSError, sqlite3.Error) as exc:
        if viz is not None:
            viz.close()
        print(f"robotd: cannot open the state store in {state_dir}: {exc} (check "
              "robot.state_dir; under systemd StateDirectory= provides it)", file=sys.stderr)
        return 1
    daemon.step_cpu = step_cpu
    if step_cpu is not None:
        step_cpu.install()
    try:
        code = asyncio.run(run_daemon(daemon, viz))
    finally:
        if step_cpu is not None:
            step_cpu.uninstall()
    for failure in daemon.start_problems:
        print(f"robotd: could not start: {failure}", file=sys.stderr)
    return code


def _state_dir(configured: str) -> Path:
    """systemd's ``$STATE_DIRECTORY`` (first entry) wins over ``robot.state_dir``."""
    from_systemd = os.environ.get("STATE_DIRECTORY", "").split(":")[0]
    return Path(from_systemd or configured)


if __name__ == "__main__":
    sys.exit(main())
