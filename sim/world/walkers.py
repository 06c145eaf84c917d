"""People who walk: a path of waypoints at a speed, once or round and round.

A ``Walk`` is a function of time, so the position of a walker is the same whoever asks
(the simulated LiDAR, the body's front sensor, the report) and costs no task: the ray caster
calls ``Person.update(t_s)`` before each cast. A walker faces where it goes; its two legs are
``leg_gap_m`` apart across that direction, and swing ``stride_m`` along it as it walks.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

LEG_RADIUS_M = 0.06
LEG_GAP_M = 0.22
STRIDE_M = 0.25


@dataclass(frozen=True, slots=True)
class Walk:
    """``points`` (>= 2, metres) walked from ``start_s`` at ``speed_mps``; ``loop``: back to
    the first point and on again, else stop at the last."""

    points: tuple[tuple[float, float], ...]
    speed_mps: float
    start_s: float
    loop: bool = False

    def __post_init__(self) -> None:
        if len(self.points) < 2:
            msg = "a walk needs at least two points"
            raise ValueError(msg)
        if not self.speed_mps > 0:
            msg = f"speed_mps: expected a positive speed, got {self.speed_mps}"
            raise ValueError(msg)

    def legs(self) -> list[tuple[tuple[float, float], tuple[float, float]]]:
        pts = list(self.points)
        if self.loop:
            pts.append(pts[0])
        return list(itertools.pairwise(pts))

    def length_m(self) -> float:
        return sum(math.dist(a, b) for a, b in self.legs())

    def at(self, t_s: float) -> tuple[float, float, float, bool]:
        """(x_m, y_m, heading_rad, walking) at time ``t_s``."""
        travelled = max(0.0, t_s - self.start_s) * self.speed_mps
        total = self.length_m()
        legs = self.legs()
        if total <= 0:
            (x, y), _ = legs[0]
            return x, y, 0.0, False
        if self.loop:
            travelled %= total
        elif travelled >= total:
            (ax, ay), (bx, by) = legs[-1]
            return bx, by, math.atan2(by - ay, bx - ax), False
        for (ax, ay), (bx, by) in legs:
            length = math.dist((ax, ay), (bx, by))
            if travelled <= length and length > 0:
                f = travelled / length
                return (ax + f * (bx - ax), ay + f * (by - ay), math.atan2(by - ay, bx - ax),
                        True)
            travelled -= length
        (ax, ay), (bx, by) = legs[-1]
        return bx, by, math.atan2(by - ay, bx - ax), True


def leg_centres(x_m: float, y_m: float, heading_rad: float, walked_m: float
                ) -> list[tuple[float, float]]:
    """The two legs' centres of a person at (x, y) facing ``heading_rad``; they swing
    opposite ways along the heading with the distance walked."""
    swing = 0.5 * STRIDE_M * math.sin(2 * math.pi * walked_m / (2 * STRIDE_M))
    c, s = math.cos(heading_rad), math.sin(heading_rad)
    half = LEG_GAP_M / 2
    return [(x_m - s * half + c * swing, y_m + c * half + s * swing),
            (x_m + s * half - c * swing, y_m - c * half - s * swing)]
