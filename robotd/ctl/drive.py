"""``robotctl drive``: a technician's teleoperation, refreshed so that the daemon's deadman
(``robotd/control/teleop.py``: 0.5 s) holds while it drives and stops the robot when it ends.

``--linear V --angular W [--for S]``: drive at V m/s and W rad/s for S seconds (default one
hold, 0.5 s), refreshed every ``REFRESH_S``, then stop. ``--keys``: drive with the keyboard
(w/s faster/slower, a/d turn, space stop, q quit), a refresh every ``REFRESH_S`` while it runs.
Ctrl-C stops the robot first.
"""

from __future__ import annotations

import select
import sys
import time
from typing import Any, TextIO

from robotd.ctl.connection import Connection

REFRESH_S = 0.2
LINEAR_STEP_MPS = 0.05
ANGULAR_STEP_RAD_S = 0.2


def drive_for(conn: Connection, linear_mps: float, angular_rad_s: float,
              duration_s: float | None) -> dict[str, Any]:
    """Drives, refreshing, for ``duration_s`` (None: one command), then stops."""
    params = {"linear_mps": linear_mps, "angular_rad_s": angular_rad_s}
    result: dict[str, Any] = conn.call("drive", params)
    if duration_s is None:
        return result
    end = time.monotonic() + duration_s
    try:
        while time.monotonic() < end:
            time.sleep(min(REFRESH_S, max(0.0, end - time.monotonic())))
            if time.monotonic() < end:
                result = conn.call("drive", params)
    finally:
        result = conn.call("drive", {"linear_mps": 0.0, "angular_rad_s": 0.0})
    return result


def drive_keys(conn: Connection, out: TextIO) -> int:
    """The keyboard mode (a terminal needed)."""
    import termios
    import tty

    if not sys.stdin.isatty():
        print("robotctl drive --keys: needs a terminal", file=sys.stderr)
        return 2
    fd = sys.stdin.fileno()
    saved = termios.tcgetattr(fd)
    v = w = 0.0
    out.write("w/s: faster/slower, a/d: turn left/right, space: stop, q: quit\n")
    try:
        tty.setcbreak(fd)
        while True:
            ready, _, _ = select.select([sys.stdin], [], [], REFRESH_S)
            if ready:
                key = sys.stdin.read(1)
                if key == "q":
                    break
                v, w = _key(key, v, w)
                out.write(f"\rlinear {v:+.2f} m/s, angular {w:+.2f} rad/s   ")
                out.flush()
            conn.call("drive", {"linear_mps": v, "angular_rad_s": w})
    finally:
        termios.tcsetattr(fd, termios.TCSADRAIN, saved)
        conn.call("drive", {"linear_mps": 0.0, "angular_rad_s": 0.0})
        out.write("\nstopped\n")
    return 0


def _key(key: str, v: float, w: float) -> tuple[float, float]:
    if key == "w":
        return round(min(1.0, v + LINEAR_STEP_MPS), 3), w
    if key == "s":
        return round(max(-1.0, v - LINEAR_STEP_MPS), 3), w
    if key == "a":
        return v, round(min(3.0, w + ANGULAR_STEP_RAD_S), 3)
    if key == "d":
        return v, round(max(-3.0, w - ANGULAR_STEP_RAD_S), 3)
    if key == " ":
        return 0.0, 0.0
    return v, w
