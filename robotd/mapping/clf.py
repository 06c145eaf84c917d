"""CARMEN ``.clf`` logs, as the public 2D SLAM benchmarks ship them: read and written.

Lines read (one message a line, fields separated by spaces; ``#`` starts a comment line):

- ``FLASER n r1..rn x y theta odom_x odom_y odom_theta ipc_timestamp hostname
  logger_timestamp``: a front laser of 180 degrees, beam i at -90 deg + i * 180 / n deg
  (n + 1 readings over 180 degrees when n is odd, as the SICK's 181-beam scans), ``x y theta``
  the laser's pose and ``odom_*`` the robot's, both in the odometry frame. FLASER carries no
  maximum range: ``flaser_max_range_m`` (the SICK LMS reports no return as 81.91 m).
- ``ROBOTLASER1 type start_angle fov resolution max_range accuracy remission_mode n r1..rn
  m rem1..remm laser_x laser_y laser_theta robot_x robot_y robot_theta tv rv forward_safety
  side_safety turn_axis ipc_timestamp hostname logger_timestamp``.
- ``TRUEPOS true_x true_y true_theta odom_x odom_y odom_theta ipc_timestamp hostname
  logger_timestamp``: the simulator's true pose (CARMEN's simulator logs it).

A range at or past the sensor's maximum is no return. A line of a known message that does not
parse, or one that is not a message at all, is skipped and counted with its line number and
why; lines of other messages (``ODOM``, ``PARAM``, ``RAWLASER1``...) are ignored.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TextIO

import numpy as np
import numpy.typing as npt

from behaviours.nav.icp import Pose
from behaviours.nav.mapping.scan import Scan, between, compose

FloatArray = npt.NDArray[np.float64]
FLASER_MAX_RANGE_M = 81.91
_WORD = re.compile(r"[A-Z][A-Z0-9_]*")
HOSTNAME = "robotd"


@dataclass(slots=True)
class ClfLog:
    scans: list[Scan] = field(default_factory=list)
    true_poses: list[tuple[float, Pose]] = field(default_factory=list)
    skipped: list[tuple[int, str]] = field(default_factory=list)
    """(line number, why) of every line that could not be read."""
    ignored: int = 0


class _Bad(ValueError):
    pass


def read_clf(path: str | Path, *, flaser_max_range_m: float = FLASER_MAX_RANGE_M) -> ClfLog:
    with Path(path).open(encoding="utf-8", errors="replace") as stream:
        return parse_clf(stream, flaser_max_range_m=flaser_max_range_m)


def parse_clf(lines: Iterable[str], *, flaser_max_range_m: float = FLASER_MAX_RANGE_M
              ) -> ClfLog:
    out = ClfLog()
    for number, line in enumerate(lines, 1):
        words = line.split()
        if not words or words[0].startswith("#"):
            continue
        kind = words[0]
        try:
            if kind == "FLASER":
                out.scans.append(_flaser(words, flaser_max_range_m))
            elif kind == "ROBOTLASER1":
                out.scans.append(_robotlaser(words))
            elif kind == "TRUEPOS":
                out.true_poses.append(_truepos(words))
            elif _WORD.fullmatch(kind):
                out.ignored += 1
            else:
                msg = f"not a CARMEN message: {kind[:20]!r}"
                raise _Bad(msg)
        except _Bad as exc:
            out.skipped.append((number, str(exc)))
    return out


class _Fields:
    def __init__(self, words: list[str]) -> None:
        self.words = words
        self.at = 1

    def number(self, what: str) -> float:
        if self.at >= len(self.words):
            msg = f"{self.words[0]}: line ends before {what}"
            raise _Bad(msg)
        word = self.words[self.at]
        self.at += 1
        try:
            value = float(word)
        except ValueError:
            msg = f"{self.words[0]}: {what}: not a number: {word[:20]!r}"
            raise _Bad(msg) from None
        if not math.isfinite(value):
            msg = f"{self.words[0]}: {what}: not finite"
            raise _Bad(msg)
        return value

    def count(self, what: str, limit: int = 100_000) -> int:
        value = self.number(what)
        if value != int(value) or not 0 <= value <= limit:
            msg = f"{self.words[0]}: {what}: expected a count, got {value}"
            raise _Bad(msg)
        return int(value)

    def numbers(self, n: int, what: str) -> FloatArray:
        if self.at + n > len(self.words):
            msg = f"{self.words[0]}: {n} {what} announced, fewer given"
            raise _Bad(msg)
        try:
            values = np.array(self.words[self.at:self.at + n], dtype=np.float64)
        except ValueError:
            msg = f"{self.words[0]}: {what}: not all numbers"
            raise _Bad(msg) from None
        self.at += n
        return values

    def pose(self, what: str) -> Pose:
        return (self.number(f"{what} x"), self.number(f"{what} y"),
                self.number(f"{what} theta"))

    def rest(self, what: str) -> float:
        """The ipc timestamp, then a hostname and the logger's timestamp (required)."""
        timestamp = self.number(f"{what} timestamp")
        if self.at + 2 != len(self.words):
            msg = (f"{self.words[0]}: expected hostname and logger timestamp to end the line, "
                   f"got {len(self.words) - self.at} fields")
            raise _Bad(msg)
        return timestamp


def _flaser(words: list[str], max_range_m: float) -> Scan:
    f = _Fields(words)
    n = f.count("num_readings")
    if n < 2:
        msg = f"FLASER: {n} readings"
        raise _Bad(msg)
    ranges = f.numbers(n, "ranges")
    laser = f.pose("laser pose")
    odom = f.pose("odometry pose")
    timestamp = f.rest("ipc")
    step = math.pi / (n - 1 if n % 2 else n)
    return Scan(timestamp, ranges, -math.pi / 2, step, max_range_m, odom, between(odom, laser))


def _robotlaser(words: list[str]) -> Scan:
    f = _Fields(words)
    f.number("laser_type")
    start = f.number("start_angle")
    f.number("field_of_view")
    resolution = f.number("angular_resolution")
    max_range = f.number("maximum_range")
    f.number("accuracy")
    f.number("remission_mode")
    n = f.count("num_readings")
    ranges = f.numbers(n, "ranges")
    f.numbers(f.count("num_remissions"), "remissions")
    laser = f.pose("laser pose")
    robot = f.pose("robot pose")
    for what in ("tv", "rv", "forward_safety_dist", "side_safety_dist", "turn_axis"):
        f.number(what)
    timestamp = f.rest("ipc")
    if not max_range > 0 or resolution == 0 or n < 2:
        msg = "ROBOTLASER1: maximum_range, angular_resolution or num_readings out of range"
        raise _Bad(msg)
    return Scan(timestamp, ranges, start, resolution, max_range, robot, between(robot, laser))


def _truepos(words: list[str]) -> tuple[float, Pose]:
    f = _Fields(words)
    true = f.pose("true pose")
    f.pose("odometry pose")
    return (f.rest("ipc"), true)


def write_clf(stream: TextIO, scans: Iterable[Scan],
              true_poses: dict[float, Pose] | None = None) -> int:
    """ROBOTLASER1 lines (and a TRUEPOS line after a scan whose timestamp has a true pose);
    no return is written as the maximum range. Returns the lines written."""
    lines = 0
    stream.write("# CARMEN log written by robotd: ROBOTLASER1 and TRUEPOS messages\n")
    for scan in scans:
        ranges = np.where(scan.returns(), scan.ranges_m, scan.max_range_m)
        laser = compose(scan.odom, scan.laser_offset)
        fov = scan.angle_increment_rad * (ranges.size - 1)
        t = f"{scan.timestamp_s:.6f}"
        stream.write(
            f"ROBOTLASER1 0 {scan.angle_min_rad:.6f} {fov:.6f} {scan.angle_increment_rad:.8f} "
            f"{scan.max_range_m:.3f} 0.01 0 {ranges.size} "
            + " ".join(f"{r:.3f}" for r in ranges)
            + f" 0 {_pose(laser)} {_pose(scan.odom)} 0 0 0 0 0 {t} {HOSTNAME} {t}\n")
        lines += 1
        if true_poses is not None and scan.timestamp_s in true_poses:
            stream.write(f"TRUEPOS {_pose(true_poses[scan.timestamp_s])} {_pose(scan.odom)} "
                         f"{t} {HOSTNAME} {t}\n")
            lines += 1
    return lines


def _pose(pose: Pose) -> str:
    return f"{pose[0]:.6f} {pose[1]:.6f} {pose[2]:.6f}"
