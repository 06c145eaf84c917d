"""robotd's output piped into a reader that stops early."""

from __future__ import annotations

import subprocess
import sys


def test_a_reader_that_stops_early_gets_no_traceback() -> None:
    """`robotd example-config | true`: exit 1, nothing on stderr (no BrokenPipeError trace)."""
    code = ("import os, sys\n"
            "r, w = os.pipe(); os.close(r); os.dup2(w, 1)\n"
            "from robotd.cli import main\n"
            "sys.exit(main(['example-config']))\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=60, check=False)
    assert done.returncode == 1
    assert "Traceback" not in done.stderr and "BrokenPipe" not in done.stderr
