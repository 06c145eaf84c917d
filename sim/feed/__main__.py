"""``python -m sim.feed SCENARIO --dir DIR``: serve a simulated robot's hardware for robotd run.

Prints ``config PATH`` once the devices are served (then ``robotd run --config PATH``), serves
until SIGINT or SIGTERM, and prints what the devices did as one JSON line when it stops.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import signal
import sys
from pathlib import Path

from robotd.logs import configure_logging
from sim.feed.feeder import feeder_for
from sim.scenario import ScenarioError


async def _serve(args: argparse.Namespace) -> int:
    work = Path(args.dir)
    try:
        feeder = feeder_for(args.scenario, work, args.seed)
    except (ScenarioError, ValueError) as exc:
        print(f"sim.feed: {exc}", file=sys.stderr)
        return 2
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGTERM, signal.SIGINT):
        loop.add_signal_handler(sig, stop.set)
    try:
        print(f"config {await feeder.open()}", flush=True)
        serving = asyncio.create_task(feeder.run(args.hold_s))
        stopping = asyncio.create_task(stop.wait())
        await asyncio.wait({serving, stopping}, return_when=asyncio.FIRST_COMPLETED)
        if serving.done() and serving.exception() is not None:
            raise serving.exception()  # type: ignore[misc]
    finally:
        figures = await feeder.close()
        with contextlib.suppress(BrokenPipeError):  # whoever read our output has gone
            print(json.dumps(figures), flush=True)
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m sim.feed", description=__doc__)
    parser.add_argument("scenario", help="a built-in scenario's name or a scenario file")
    parser.add_argument("--dir", required=True, help="where the ports, files and config go")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--hold-s", type=float, default=0.0,
                        help="start the script this long after the daemon first answers")
    parser.add_argument("--log-level", default="warning")
    args = parser.parse_args(argv)
    Path(args.dir).mkdir(parents=True, exist_ok=True)
    configure_logging(args.log_level, mode="json")
    return asyncio.run(_serve(args))


if __name__ == "__main__":
    sys.exit(main())
