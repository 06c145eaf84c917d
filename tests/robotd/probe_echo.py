"""A probe module for the CLI's tests: prints its parsed options."""

from __future__ import annotations

import argparse
import json


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--port")


async def run(args: argparse.Namespace) -> int:
    print(json.dumps(vars(args)))
    return 0
