"""What ``robotd sim`` prints: state transitions, one progress line, and the summary."""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path
from typing import Any, TextIO


def process_age_s() -> float:
    """How long this process has run (Linux: its start time in /proc/self/stat against
    /proc/uptime, in clock ticks); 0 where they cannot be read."""
    try:
        after_name = Path("/proc/self/stat").read_text().rsplit(")", 1)[1].split()
        start_ticks = int(after_name[19])  # field 22, starttime; fields 3.. follow the name
        uptime_s = float(Path("/proc/uptime").read_text().split()[0])
    except (OSError, ValueError, IndexError):
        return 0.0
    return max(0.0, uptime_s - start_ticks / os.sysconf("SC_CLK_TCK"))


class SimConsole:
    """Prints transitions as lines and keeps one progress line updated in place on a TTY."""

    def __init__(self, *, quiet: bool = False, stream: TextIO | None = None,
                 refresh_s: float = 0.25, from_process_start: bool = False) -> None:
        """``from_process_start``: the wall time counts from the process's start (Python's
        start-up and imports included: what the user waited), not from here."""
        self.quiet = quiet
        self.stream = stream or sys.stdout
        self.tty = self.stream.isatty()
        self.refresh_s = refresh_s
        self._wall_start = time.monotonic() - (process_age_s() if from_process_start else 0.0)
        self._last_refresh = 0.0
        self._progress_shown = False

    def wall_s(self) -> float:
        return time.monotonic() - self._wall_start

    def line(self, text: str) -> None:
        if self.quiet:
            return
        self._clear_progress()
        print(text, file=self.stream, flush=True)

    def transition(self, t_s: float, robot: str, src: str, dst: str, trigger: str) -> None:
        """One robot's state change; the robot is named even when it is the only one (the
        other lines of a run name theirs)."""
        self.line(f"[{t_s:8.2f} s] {robot}: {src} -> {dst}  ({trigger})")

    def event(self, t_s: float, text: str) -> None:
        self.line(f"[{t_s:8.2f} s] {text}")

    def progress(self, t_s: float, states: dict[str, str]) -> None:
        """Refresh the progress line (at most every ``refresh_s`` of wall time)."""
        if self.quiet or not self.tty:
            return
        now = time.monotonic()
        if now - self._last_refresh < self.refresh_s:
            return
        self._last_refresh = now
        wall = max(1e-9, self.wall_s())
        state_text = ", ".join(f"{k}={v}" for k, v in states.items()) if len(states) > 1 \
            else next(iter(states.values()), "")
        text = f"  t={t_s:7.1f} s  x{t_s / wall:6.0f}  {state_text}"
        self.stream.write("\r\x1b[K" + text)
        self.stream.flush()
        self._progress_shown = True

    def _clear_progress(self) -> None:
        if self._progress_shown:
            self.stream.write("\r\x1b[K")
            self._progress_shown = False

    def summary(self, *, scenario: str, ok: bool, reasons: list[str], sim_s: float,
                figures: dict[str, Any], report_dir: str | None,
                run_wall_s: float | None = None) -> None:
        """Always printed, even with --quiet: the result and why. ``run_wall_s``: the wall
        time of the simulation itself (robots started, run, stopped), without loading the
        simulator and drawing the report - what the speed factor is of."""
        self._clear_progress()
        wall = max(1e-9, self.wall_s())
        out = self.stream
        print(f"\nscenario {scenario}: {'SUCCESS' if ok else 'FAILED'}", file=out)
        for reason in reasons:
            print(f"  - {reason}", file=out)
        if run_wall_s is None:
            print(f"  virtual time {sim_s:.1f} s, wall time {wall:.2f} s, "
                  f"speed x{sim_s / wall:.0f}", file=out)
        else:
            run = max(1e-9, run_wall_s)
            print(f"  virtual time {sim_s:.1f} s, wall time {wall:.2f} s (simulation {run:.2f} s,"
                  f" speed x{sim_s / run:.0f}; start-up, loading and report {wall - run:.2f} s)",
                  file=out)
        for robot, fig in figures.items():
            parts = ", ".join(f"{k} {v}" for k, v in fig.items())
            print(f"  {robot}: {parts}", file=out)
        if report_dir:
            mcap = Path(report_dir) / "run.mcap"
            files = ["events.jsonl", "trajectory.png"] + (["run.mcap"] if mcap.exists() else [])
            print("  report: " + ", ".join(f"{report_dir}/{f}" for f in files), file=out)
        out.flush()
