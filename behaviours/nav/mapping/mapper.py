"""Offline mapping: key scans matched against the growing map, loop closures, a pose graph.

A scan becomes a key scan when odometry says the robot moved ``key_distance_m`` or turned
``key_angle_rad`` since the last one. Each key scan is fitted (``ScanMatcher.fit_local``: the
correlative search over a likelihood field, polished by ICP, refused when ambiguous) to a
submap of the previous ``submap_scans`` key scans at their current estimates, starting from
the odometry's guess; the fit, or the odometry when the fit is refused, is the edge to the
previous key scan. Every ``loop_every`` key scans, the nearest older key scan (at least
``loop_min_separation`` key scans back and within ``loop_search_m``) and its neighbours are a
submap the new scan is fitted to with a wider window (1 m, 15 deg); a fit that is accepted
(clear of any rival pose by ``loop_margin``), scores at least ``loop_min_score`` and does not
lie at the window's edge (the truth could be beyond it) is a loop-closure edge, and the graph
is solved again. At the end the graph is solved, every scan's pose is its key scan's
plus the odometry since, and the grid is rendered from the key scans (``log_odds``).
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import cv2
import numpy as np
import numpy.typing as npt
import structlog

from behaviours.motion.moves import wrap
from behaviours.nav.distance_field import DistanceField
from behaviours.nav.grid import Grid
from behaviours.nav.icp import Pose, transform
from behaviours.nav.mapping.log_odds import RenderConfig, render
from behaviours.nav.mapping.pose_graph import Edge, PoseGraph
from behaviours.nav.mapping.scan import Scan, between, compose
from behaviours.nav.scan_match import MatchConfig, ScanMatcher
from hal.occupancy_map import OccupancyMap

log = structlog.get_logger(__name__)
FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class MappingConfig:
    key_distance_m: float = 0.3
    key_angle_rad: float = math.radians(10)
    submap_scans: int = 6
    wall_scans: int = 3
    """Of the submap's key scans, the newest this many give ICP its wall segments."""
    wall_tolerance_m: float = 0.02
    """ICP's walls: each scan's polyline simplified to within this."""
    wall_break_m: float = 0.25
    match_points: int = 180
    match_window_m: float = 0.15
    match_window_rad: float = math.radians(5)
    match_sigma_m: float = 0.02
    match_sigma_rad: float = math.radians(0.5)
    odom_sigma_m: float = 0.02
    odom_sigma_per_m: float = 0.05
    odom_sigma_rad: float = math.radians(1.0)
    loop_every: int = 5
    loop_min_separation: int = 40
    loop_search_m: float = 2.5
    loop_neighbours: int = 3
    loop_window_m: float = 1.0
    loop_window_rad: float = math.radians(15)
    loop_edge_m: float = 0.1
    loop_edge_rad: float = math.radians(2)
    """A loop fit this near the window's edge is refused: the truth may lie outside it."""
    loop_min_score: float = 0.7
    loop_margin: float = 0.05
    """A loop fit must beat a clearly different pose by this (sequential fits: 0.02)."""
    loop_sigma_m: float = 0.03
    loop_sigma_rad: float = math.radians(0.8)
    resolution_m: float = 0.05


@dataclass(slots=True)
class MappingResult:
    grid: OccupancyMap
    key_indices: list[int]
    key_poses: list[Pose]
    scan_poses: list[Pose]
    graph: PoseGraph
    matches_accepted: int = 0
    matches_refused: int = 0
    loops_tried: int = 0
    timings_s: dict[str, float] = field(default_factory=dict)


class Mapper:
    """Builds a map from scans in time order (``add``), then ``finish``."""

    def __init__(self, config: MappingConfig | None = None) -> None:
        self.config = config or MappingConfig()
        self.graph = PoseGraph()
        self.key_scans: list[Scan] = []
        self.key_indices: list[int] = []
        self.scans: list[Scan] = []
        self.key_of_scan: list[int] = []
        self.accepted = 0
        self.refused = 0
        self.loops_tried = 0
        self.match_s = 0.0
        self.loop_s = 0.0
        self.loop_fits_s: list[float] = []
        self.key_fits_s: list[float] = []

    def add(self, scan: Scan) -> None:
        c = self.config
        index = len(self.scans)
        self.scans.append(scan)
        if self.key_scans:
            last = self.key_scans[-1]
            step = between(last.odom, scan.odom)
            if math.hypot(step[0], step[1]) < c.key_distance_m and abs(step[2]) < c.key_angle_rad:
                self.key_of_scan.append(len(self.key_scans) - 1)
                return
        self._add_key(scan, index)
        self.key_of_scan.append(len(self.key_scans) - 1)

    def _add_key(self, scan: Scan, index: int) -> None:
        c = self.config
        if not self.key_scans:
            self.graph.add_node(scan.odom)
            self.key_scans.append(scan)
            self.key_indices.append(index)
            return
        started = time.perf_counter()
        prev = len(self.key_scans) - 1
        odom_step = between(self.key_scans[-1].odom, scan.odom)
        guess = compose(self.graph.poses[prev], odom_step)
        node = self.graph.add_node(guess)
        self.key_scans.append(scan)
        self.key_indices.append(index)
        refs = list(range(max(0, prev - c.submap_scans + 1), prev + 1))
        fit = self._matcher(refs).fit_local(
            self._points(scan), guess, window_m=c.match_window_m, window_rad=c.match_window_rad,
            distinct_m=c.match_window_m, distinct_rad=c.match_window_rad)
        if fit.accepted:
            self.accepted += 1
            self.graph.poses[node] = fit.pose
            measured = between(self.graph.poses[prev], fit.pose)
            self.graph.add_edge(Edge(prev, node, measured, c.match_sigma_m, c.match_sigma_rad,
                                     "match"))
        else:
            self.refused += 1
            dist = math.hypot(odom_step[0], odom_step[1])
            self.graph.add_edge(Edge(prev, node, odom_step,
                                     c.odom_sigma_m + c.odom_sigma_per_m * dist,
                                     c.odom_sigma_rad, "odometry"))
        elapsed = time.perf_counter() - started
        self.match_s += elapsed
        self.key_fits_s.append(elapsed)
        if node % c.loop_every == 0:
            self._try_loop(node)

    def _try_loop(self, node: int) -> None:
        c = self.config
        here = self.graph.poses[node]
        older = node - c.loop_min_separation
        if older <= 0:
            return
        xy = np.asarray(self.graph.poses[:older], dtype=np.float64)[:, :2]
        dist = np.hypot(xy[:, 0] - here[0], xy[:, 1] - here[1])
        best = int(np.argmin(dist))
        if float(dist[best]) > c.loop_search_m:
            return
        started = time.perf_counter()
        self.loops_tried += 1
        refs = list(range(max(0, best - c.loop_neighbours),
                          min(older, best + c.loop_neighbours + 1)))
        fit = self._matcher(refs, walls_from=refs, margin=c.loop_margin).fit_local(
            self._points(self.key_scans[node]), here, window_m=c.loop_window_m,
            window_rad=c.loop_window_rad, distinct_m=0.3, distinct_rad=math.radians(8))
        inside = (fit.accepted
                  and abs(fit.pose[0] - here[0]) < c.loop_window_m - c.loop_edge_m
                  and abs(fit.pose[1] - here[1]) < c.loop_window_m - c.loop_edge_m
                  and abs(wrap(fit.pose[2] - here[2])) < c.loop_window_rad - c.loop_edge_rad)
        moved = math.hypot(fit.pose[0] - here[0], fit.pose[1] - here[1])
        if fit.accepted and fit.score >= c.loop_min_score and inside:
            measured = between(self.graph.poses[best], fit.pose)
            self.graph.add_edge(Edge(best, node, measured, c.loop_sigma_m, c.loop_sigma_rad,
                                     "loop"))
            self.graph.optimise()
            log.info("mapping.loop_closed", node=node, to=best, score=round(fit.score, 3),
                     moved_m=round(moved, 3))
        else:
            log.debug("mapping.loop_refused", node=node, to=best, score=round(fit.score, 3),
                      reason=fit.reason or ("low score" if fit.score < c.loop_min_score
                                            else "at the window's edge"))
        elapsed = time.perf_counter() - started
        self.loop_s += elapsed
        self.loop_fits_s.append(elapsed)

    def _points(self, scan: Scan) -> FloatArray:
        pts = scan.points()
        n = self.config.match_points
        if pts.shape[0] > n:
            pts = pts[np.linspace(0, pts.shape[0] - 1, n).astype(np.intp)]
        return pts

    def _matcher(self, refs: Sequence[int], walls_from: Sequence[int] | None = None,
                 margin: float = 0.02) -> ScanMatcher:
        """A matcher over the key scans ``refs`` at their current estimates: their points as
        the grid, and polylines through the newest ``wall_scans`` of them as ICP's walls."""
        c = self.config
        clouds = [transform(self.key_scans[k].points(), self.graph.poses[k]) for k in refs]
        cloud = np.vstack(clouds)
        res = c.resolution_m
        x0 = math.floor((float(cloud[:, 0].min()) - 1.0) / res) * res
        y0 = math.floor((float(cloud[:, 1].min()) - 1.0) / res) * res
        cols = math.ceil((float(cloud[:, 0].max()) + 1.0 - x0) / res) + 1
        rows = math.ceil((float(cloud[:, 1].max()) + 1.0 - y0) / res) + 1
        occupied = np.zeros((rows, cols), dtype=np.bool_)
        r = np.floor((cloud[:, 1] - y0) / res).astype(np.intp)
        q = np.floor((cloud[:, 0] - x0) / res).astype(np.intp)
        occupied[r, q] = True
        field = DistanceField(Grid(occupied, res, x0, y0))
        chosen = walls_from if walls_from is not None else refs[-c.wall_scans:]
        walls = np.vstack([_polyline(transform(self.key_scans[k].points(),
                                               self.graph.poses[k]),
                                     c.wall_tolerance_m, c.wall_break_m) for k in chosen])
        return ScanMatcher(field, walls, MatchConfig(sigma_m=0.05, min_score=0.5, margin=margin))

    def finish(self, render_config: RenderConfig | None = None) -> MappingResult:
        started = time.perf_counter()
        self.graph.optimise()
        solve_s = time.perf_counter() - started
        scan_poses = [compose(self.graph.poses[k], between(self.key_scans[k].odom, s.odom))
                      for s, k in zip(self.scans, self.key_of_scan, strict=True)]
        started = time.perf_counter()
        rc = render_config or RenderConfig(resolution_m=self.config.resolution_m)
        grid = render(self.key_scans, self.graph.poses, rc)
        render_s = time.perf_counter() - started
        return MappingResult(grid, list(self.key_indices), list(self.graph.poses), scan_poses,
                             self.graph, self.accepted, self.refused, self.loops_tried,
                             {"match_s": self.match_s, "loop_s": self.loop_s,
                              "solve_s": solve_s, "render_s": render_s})


def build_map(scans: Sequence[Scan], config: MappingConfig | None = None) -> MappingResult:
    mapper = Mapper(config)
    for scan in scans:
        mapper.add(scan)
    if not mapper.key_scans:
        msg = "no scans to map"
        raise ValueError(msg)
    return mapper.finish()


def _polyline(points: FloatArray, tolerance_m: float, break_m: float) -> FloatArray:
    """Segments through a scan's points in beam order, not across a gap wider than
    ``break_m`` (a depth jump: no wall there), each unbroken run simplified (Douglas-Peucker,
    ``cv2.approxPolyDP``) to within ``tolerance_m``: a straight wall is one segment, so ICP's
    nearest-wall search, points x walls, stays small."""
    if points.shape[0] < 2:
        return np.zeros((0, 4))
    gaps = np.hypot(*(np.diff(points, axis=0).T)) > break_m
    starts = np.concatenate(([0], np.nonzero(gaps)[0] + 1))
    ends = np.concatenate((starts[1:], [points.shape[0]]))
    parts = []
    for a, b in zip(starts.tolist(), ends.tolist(), strict=True):
        if b - a < 2:
            continue
        run = points[a:b].astype(np.float32).reshape(-1, 1, 2)
        corners = cv2.approxPolyDP(run, tolerance_m, False).reshape(-1, 2).astype(np.float64)
        if corners.shape[0] >= 2:
            parts.append(np.hstack((corners[:-1], corners[1:])))
    return np.vstack(parts) if parts else np.zeros((0, 4))
