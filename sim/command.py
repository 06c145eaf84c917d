"""``robotd sim``'s arguments and run, plugged into the ``robotd`` command line (the entry
point ``robotd.simulator: command``; robotd/extensions.py)."""

from __future__ import annotations

import argparse

from robotd.profiles import DEFAULT_SCENARIO, PROFILES
from sim.scenario import builtin_names

HELP = "run the daemon on the simulator"


def _positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        msg = f"expected a number, got {text!r}"
        raise argparse.ArgumentTypeError(msg) from None
    if not value > 0:
        msg = f"must be > 0, got {text}"
        raise argparse.ArgumentTypeError(msg)
    return value


def add_arguments(sim: argparse.ArgumentParser) -> None:
    """``robotd sim [SCENARIO] [--config PATH] [--seed N] [--realtime | --speed X] ...``."""
    sim.epilog = (
        "exit status: 0 when the scenario's success conditions hold, 1 when one does not "
        "(the reasons are printed), 2 for a scenario or option that cannot be used; "
        "more robots than one get sockets PATH.NAME. Robot profiles: " + "; ".join(
            f"{spec.name}: {spec.summary}" for spec in PROFILES.specs()))
    sim.add_argument("scenario", nargs="?", default=DEFAULT_SCENARIO, metavar="SCENARIO",
                     help=f"built-in scenario ({', '.join(builtin_names())}; default "
                          f"{DEFAULT_SCENARIO}) or a TOML file")
    sim.add_argument("--config", help="robot config laid over the scenario's")
    sim.add_argument("--seed", type=int, help="random seed (same seed, same run)")
    pace = sim.add_mutually_exclusive_group()
    pace.add_argument("--realtime", action="store_true", help="run against the wall clock")
    pace.add_argument("--speed", type=_positive_float, metavar="X",
                      help="X times faster than real time")
    sim.add_argument("--socket", help="control socket path (for robotctl)")
    sim.add_argument("--report", metavar="DIR",
                     help="write events.jsonl, trajectory.png and run.mcap (virtual time)")
    sim.add_argument("--viz", action="store_true",
                     help="serve the Foxglove live view (docs/live-view.md)")
    sim.add_argument("--viz-host", default="127.0.0.1", metavar="HOST",
                     help="address the live view listens on (default: %(default)s)")
    sim.add_argument("--viz-port", type=int, default=8765, metavar="PORT",
                     help="the live view's port, 0 for any free one (default: %(default)s)")
    sim.add_argument("--quiet", action="store_true", help="print only the result")
    sim.add_argument("--fleet-url", metavar="URL",
                     help="the robots report to this fleet server (robotd-fleet serve) instead "
                          "of the scenario's own; its people are real (run with --realtime or "
                          "--speed)")
    sim.add_argument("--fleet-token-file", metavar="FILE",
                     help="the robots' token for --fleet-url (one for all robots)")
    sim.add_argument("--mcu", choices=("fake", "simavr"), default="fake",
                     help="motor board: the Python fake MCU or the firmware in simavr")


def run(args: argparse.Namespace) -> int:
    """Run the scenario: 0 success, 1 a condition failed, 2 bad input, 130 interrupted."""
    if getattr(args, "fleet_url", None) and not (args.realtime or args.speed):
        # A virtual clock races ahead of the server's wall clock: reports would flood it and
        # its timeouts would never come.
        print("robotd sim: --fleet-url needs --realtime or --speed X (the server keeps the "
              "wall clock)")
        return 2
    from sim.runner import run_sim  # the daemon, the drivers, the live view: only to run

    code: int = run_sim(args)
    return code
