"""People in the LiDAR scan: points the map does not explain, clustered, sized, tracked.

A point is unexplained when it lies farther than ``unexplained_m`` from every occupied map
cell (the distance field at its map position, through the localised pose). Unexplained points
next to each other in the sweep (closer than ``cluster_gap_m``, seed: 0.3 m) form a cluster;
a cluster is a leg (0.05-0.25 m wide) or a body (0.3-0.6 m: a torso, or two legs close
together; between 0.25 and 0.3 m it is two legs seen as one), and two legs within
``leg_pair_m`` are one person.

The seed's fixed 10 points cannot be met far out: at 0.8 degrees a point (the LD19, 4500
points/s at 10 Hz) a 0.3 m body at 3 m spans 7 points, a 0.1 m leg 2. So the count a cluster
needs follows from its own width and range: ``point_fill`` (0.5) of the points that width
spans there, never more than the seed's 10 (what a person close by has) and never fewer than
``min_points_floor`` (3, so two stray returns are never a person). Sparse clutter is thus
rejected at every range and a person is kept to the range where the sensor still gives 3.

People are tracked in the map frame (the robot's own motion does not move them): greedy
nearest neighbour within ``track_gate_m``, a track id that lasts while the person is seen
again within ``track_timeout_s``, and a smoothed velocity. Each person is reported in the
robot's frame (seed property 25) and the map's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from behaviours.nav.localisation.config import PeopleConfig
from behaviours.nav.localisation.likelihood_field import DistanceGrid
from hal.readings import LidarScan

FloatArray = npt.NDArray[np.float64]
VELOCITY_SMOOTHING = 0.5


@dataclass(frozen=True, slots=True)
class Cluster:
    """A group of unexplained points: centroid in the robot's frame, size, what it looks like."""

    x_m: float
    y_m: float
    width_m: float
    points: int
    kind: str  # "leg", "legs" (a pair), "body"

    @property
    def range_m(self) -> float:
        return math.hypot(self.x_m, self.y_m)


@dataclass(frozen=True, slots=True)
class Person:
    """A tracked person: robot frame (x ahead, y left) and map frame, velocity in the map."""

    track_id: int
    x_m: float
    y_m: float
    map_x_m: float
    map_y_m: float
    vx_mps: float
    vy_mps: float
    width_m: float
    points: int
    kind: str
    t_s: float

    @property
    def range_m(self) -> float:
        return math.hypot(self.x_m, self.y_m)

    @property
    def bearing_rad(self) -> float:
        return math.atan2(self.y_m, self.x_m)


def min_points(width_m: float, range_m: float, step_rad: float, cfg: PeopleConfig) -> int:
    """Points a cluster of this width at this range needs (see the module's docstring)."""
    spans = width_m / max(range_m * step_rad, 1e-9)
    need = math.ceil(cfg.point_fill * spans)
    return max(cfg.min_points_floor, min(cfg.min_points, need))


def unexplained_points(scan: LidarScan, pose: FloatArray, grid: DistanceGrid | None,
                       cfg: PeopleConfig) -> FloatArray:
    """Robot-frame points, in sweep order, within range and not explained by the map."""
    pts = scan.points_xy()
    if pts.shape[0] == 0:
        return pts
    pts = pts[np.hypot(pts[:, 0], pts[:, 1]) <= cfg.max_range_m]
    if grid is None or pts.shape[0] == 0:
        return pts
    c, s = math.cos(pose[2]), math.sin(pose[2])
    mx = pose[0] + c * pts[:, 0] - s * pts[:, 1]
    my = pose[1] + s * pts[:, 0] + c * pts[:, 1]
    far = grid.distance_at(mx, my, math.inf) > cfg.unexplained_m
    result: FloatArray = pts[far]
    return result


def split_by_gap(pts: FloatArray, gap_m: float) -> list[FloatArray]:
    """Consecutive points closer than ``gap_m`` together; the sweep's ends join if close."""
    n = pts.shape[0]
    if n == 0:
        return []
    steps = np.hypot(np.diff(pts[:, 0]), np.diff(pts[:, 1]))
    breaks = np.nonzero(steps > gap_m)[0] + 1
    groups = np.split(pts, breaks)
    if len(groups) > 1 and math.dist(pts[-1], pts[0]) <= gap_m:
        groups[0] = np.vstack((groups.pop(), groups[0]))
    return groups


def classify(group: FloatArray, step_rad: float, cfg: PeopleConfig) -> Cluster | None:
    """A leg or a body, or None (wrong width, too few points for its width and range)."""
    cx, cy = float(group[:, 0].mean()), float(group[:, 1].mean())
    range_m = math.hypot(cx, cy)
    # Angular extent: the circle less the widest empty arc (robust to the sweep's wrap at
    # +-pi falling inside the cluster).
    bearings = np.sort(np.arctan2(group[:, 1], group[:, 0]))
    gaps = np.diff(bearings, append=bearings[0] + 2 * np.pi)
    span_rad = float(2 * np.pi - gaps.max())
    # Width across the line of sight: the chord would add depth (one leg behind the other).
    width = range_m * span_rad
    if width < cfg.leg_min_width_m or width > cfg.body_max_width_m:
        return None
    if width <= cfg.leg_max_width_m:
        kind = "leg"
    elif width < cfg.body_min_width_m:
        kind = "legs"  # two legs seen as one cluster, between a leg and a body
    else:
        kind = "body"
    if group.shape[0] < min_points(width, range_m, step_rad, cfg):
        return None
    return Cluster(cx, cy, width, int(group.shape[0]), kind)


def pair_legs(clusters: list[Cluster], pair_m: float) -> list[Cluster]:
    """Two legs within ``pair_m`` of each other become one person (closest pairs first)."""
    legs = [c for c in clusters if c.kind == "leg"]
    out = [c for c in clusters if c.kind != "leg"]
    pairs = sorted(
        ((math.dist((a.x_m, a.y_m), (b.x_m, b.y_m)), i, j)
         for i, a in enumerate(legs) for j, b in enumerate(legs) if i < j),
    )
    used: set[int] = set()
    for d, i, j in pairs:
        if d > pair_m or i in used or j in used:
            continue
        a, b = legs[i], legs[j]
        used.update((i, j))
        out.append(Cluster((a.x_m + b.x_m) / 2, (a.y_m + b.y_m) / 2, d + (a.width_m + b.width_m)
                           / 2, a.points + b.points, "legs"))
    out.extend(leg for k, leg in enumerate(legs) if k not in used)
    return out


def detect(scan: LidarScan, pose: FloatArray, grid: DistanceGrid | None,
           cfg: PeopleConfig) -> list[Cluster]:
    """People candidates in one scan (robot frame), nearest first."""
    count = scan.angles_rad.shape[0]
    step_rad = 2 * math.pi / count if count else math.inf
    pts = unexplained_points(scan, pose, grid, cfg)
    kept = [c for g in split_by_gap(pts, cfg.cluster_gap_m)
            if (c := classify(g, step_rad, cfg)) is not None]
    return sorted(pair_legs(kept, cfg.leg_pair_m), key=lambda c: c.range_m)


@dataclass(slots=True)
class _Track:
    track_id: int
    x_m: float
    y_m: float
    vx_mps: float
    vy_mps: float
    seen_s: float


class PeopleTracker:
    """Detections joined into tracks across scans (nearest neighbour within a gate)."""

    def __init__(self, cfg: PeopleConfig, grid: DistanceGrid | None) -> None:
        self.cfg = cfg
        self.grid = grid
        self._tracks: list[_Track] = []
        self._next_id = 1

    def update(self, scan: LidarScan, pose: FloatArray, now_s: float) -> list[Person]:
        """Detect in ``scan`` seen from map ``pose``; returns the people seen in it."""
        cfg = self.cfg
        self._tracks = [t for t in self._tracks if now_s - t.seen_s <= cfg.track_timeout_s]
        found = detect(scan, pose, self.grid, cfg)
        c, s = math.cos(pose[2]), math.sin(pose[2])
        in_map = [(pose[0] + c * d.x_m - s * d.y_m, pose[1] + s * d.x_m + c * d.y_m)
                  for d in found]
        match = self._associate(in_map)
        people = []
        for k, (det, (mx, my)) in enumerate(zip(found, in_map, strict=True)):
            track = match.get(k)
            if track is None:
                track = _Track(self._next_id, mx, my, 0.0, 0.0, now_s)
                self._next_id += 1
                self._tracks.append(track)
            else:
                dt = now_s - track.seen_s
                if dt > 0:
                    a = VELOCITY_SMOOTHING
                    track.vx_mps = a * track.vx_mps + (1 - a) * (mx - track.x_m) / dt
                    track.vy_mps = a * track.vy_mps + (1 - a) * (my - track.y_m) / dt
                track.x_m, track.y_m, track.seen_s = mx, my, now_s
            people.append(Person(track.track_id, det.x_m, det.y_m, mx, my, track.vx_mps,
                                 track.vy_mps, det.width_m, det.points, det.kind, now_s))
        return people

    def _associate(self, in_map: list[tuple[float, float]]) -> dict[int, _Track]:
        pairs = sorted(
            (math.dist(p, (t.x_m, t.y_m)), k, i)
            for k, p in enumerate(in_map) for i, t in enumerate(self._tracks)
        )
        match: dict[int, _Track] = {}
        taken: set[int] = set()
        for d, k, i in pairs:
            if d > self.cfg.track_gate_m or k in match or i in taken:
                continue
            match[k] = self._tracks[i]
            taken.add(i)
        return match
