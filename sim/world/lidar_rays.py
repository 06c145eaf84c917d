"""What a LiDAR on a simulated robot sees: beams cast in the world, all at once in numpy.

``LidarRays(world, body, ...)`` is the ``ranges(angles)`` function a ``SimLd19`` asks for
each group of packets: the angles (sensor frame, counter-clockwise) become beams from the
sensor's place on the body's pose now, and each beam's range is the nearest of

- the walls (scenario walls, boxes, a ``world.map``'s occupied cells' sides): one vectorised
  beam x segment intersection, over the segments whose angular extent, seen from the
  sensor, overlaps the group's arc (a group spans a few degrees, so most segments drop out
  before the intersection). A map's thousands of cell sides take two more steps: they are
  binned in square tiles, and a tile whose bounding circle, seen from the sensor, misses the
  arc is dropped whole; the segments left are met nearest first, a chunk at a time, and a
  beam whose hit is nearer than the next chunk's nearest segment is done (in a hall most
  beams end on the first chunk: the walls behind are never intersected);
- people (two legs or a body circle, walking on their paths) and the other robots (a circle
  each): a beam x circle intersection;
- the dock (its box), when the world has one.

A beam that meets a wall at a grazing angle (more than ``grazing_deg`` from the wall's
normal) gives no return (inf), as a real one scatters away; so does a beam past range
(``SimLd19`` reports those as distance 0). The sensor's noise is added by ``SimLd19``.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from sim.world.body import DiffDriveBody
from sim.world.floor_plan import World

FloatArray = npt.NDArray[np.float64]


class LidarRays:
    """The ``ranges`` function of a LiDAR mounted on ``body`` (mount in the body's frame)."""

    def __init__(self, world: World, body: DiffDriveBody, *, mount_x_m: float = 0.0,
                 mount_y_m: float = 0.0, mount_yaw_rad: float = 0.0,
                 grazing_deg: float = 80.0, clock: Callable[[], float] | None = None) -> None:
        self.world = world
        self.body = body
        self.mount = (mount_x_m, mount_y_m, mount_yaw_rad)
        self.cos_grazing = math.cos(math.radians(grazing_deg))
        self.clock = clock
        self.casts = 0
        self.beams = 0
        self._walls_key: object = None
        self._seg = np.zeros((0, 4))
        self._normal = np.zeros((0, 2))
        self._tiles: WallTiles | None = None

    def _segments(self) -> tuple[FloatArray, FloatArray]:
        walls = self.world.walls
        dock = self.world.dock
        key = (id(walls), walls.shape[0], id(dock))
        if key != self._walls_key:
            parts = [walls.reshape(-1, 4)]
            if dock is not None:
                parts.append(dock_box(dock.x_m, dock.y_m, dock.heading_rad, dock.width_m,
                                      dock.depth_m))
            seg = np.concatenate(parts).astype(np.float64)
            ex, ey = seg[:, 2] - seg[:, 0], seg[:, 3] - seg[:, 1]
            length = np.hypot(ex, ey)
            length[length == 0] = 1.0
            self._seg = seg
            self._normal = np.column_stack((-ey / length, ex / length))
            self._walls_key = key
            self._tiles = WallTiles(seg) if seg.shape[0] > _TILED_FROM else None
        return self._seg, self._normal

    def sensor_pose(self) -> tuple[float, float, float]:
        pose = self.body.pose
        mx, my, myaw = self.mount
        c, s = math.cos(pose.heading_rad), math.sin(pose.heading_rad)
        return (pose.x_m + c * mx - s * my, pose.y_m + s * mx + c * my,
                pose.heading_rad + myaw)

    def __call__(self, angles_rad: FloatArray) -> FloatArray:
        angles = np.asarray(angles_rad, dtype=np.float64).reshape(-1)
        self.casts += 1
        self.beams += angles.size
        x, y, heading = self.sensor_pose()
        world_angles = angles + heading
        seg, normal = self._segments()
        if self._tiles is not None:
            idx = self._tiles.facing(x, y, world_angles)
            out = cast_nearest_first(seg[idx], normal[idx], x, y, world_angles,
                                     self.cos_grazing)
        else:
            out = cast_segments(seg, normal, x, y, world_angles, self.cos_grazing)
        circles = self.circles()
        if circles.shape[0]:
            out = np.minimum(out, cast_circles(circles, x, y, world_angles))
        return out

    def circles(self) -> FloatArray:
        """(x, y, r) of the people's legs (or bodies) and the other robots now."""
        t_s = self.clock() if self.clock is not None else 0.0
        rows: list[tuple[float, float, float]] = []
        for person in self.world.people:
            person.update(t_s)
            if person.present:
                rows += person.leg_circles(t_s)
        for other in self.body.others:
            o = other.pose
            rows.append((o.x_m, o.y_m, other.params.radius_m))
        return np.asarray(rows, dtype=np.float64).reshape(-1, 3)


_TILED_FROM = 256
"""Worlds with more wall segments than this (a map's cell sides) are culled by tiles first."""
_TILE_M = 2.0


class WallTiles:
    """Wall segments binned by their middle in ``_TILE_M`` squares, each tile with the circle
    round its segments (long ones reach out of their tile: the circle covers them whole)."""

    def __init__(self, seg: FloatArray, tile_m: float = _TILE_M) -> None:
        mid_x = (seg[:, 0] + seg[:, 2]) / 2
        mid_y = (seg[:, 1] + seg[:, 3]) / 2
        key = (np.floor(mid_x / tile_m).astype(np.int64) * 1_000_003
               + np.floor(mid_y / tile_m).astype(np.int64))
        order = np.argsort(key, kind="stable")
        _uniq, starts = np.unique(key[order], return_index=True)
        self.members = np.split(order, starts[1:])
        cx, cy, radius = [], [], []
        for idx in self.members:
            xs = np.concatenate((seg[idx, 0], seg[idx, 2]))
            ys = np.concatenate((seg[idx, 1], seg[idx, 3]))
            x0, x1, y0, y1 = xs.min(), xs.max(), ys.min(), ys.max()
            cx.append((x0 + x1) / 2)
            cy.append((y0 + y1) / 2)
            radius.append(math.hypot(x1 - x0, y1 - y0) / 2)
        self.cx, self.cy = np.array(cx), np.array(cy)
        self.radius = np.array(radius)

    def facing(self, x_m: float, y_m: float, angles_rad: FloatArray) -> npt.NDArray[np.intp]:
        """Indices (ascending) of the segments of the tiles that may lie in the beams' arc."""
        mid = float(np.arctan2(np.sin(angles_rad).mean(), np.cos(angles_rad).mean()))
        half = float(np.abs(_wrap(angles_rad - mid)).max())
        dx, dy = self.cx - x_m, self.cy - y_m
        dist = np.hypot(dx, dy)
        with np.errstate(invalid="ignore", divide="ignore"):
            spread = np.arcsin(np.clip(self.radius / dist, 0.0, 1.0))
        off = np.abs(_wrap(np.arctan2(dy, dx) - mid))
        near = (dist <= self.radius * 1.0001 + 1e-9) | (off <= half + spread + 1e-6)
        picked = [self.members[i] for i in np.flatnonzero(near)]
        if not picked:
            return np.zeros(0, dtype=np.intp)
        return np.sort(np.concatenate(picked))


def dock_box(x_m: float, y_m: float, heading_rad: float, width_m: float, depth_m: float
             ) -> FloatArray:
    """The dock's outline: its face's middle at (x, y), looking along ``heading_rad``."""
    c, s = math.cos(heading_rad), math.sin(heading_rad)
    corners = []
    for fwd, left in ((0.0, width_m / 2), (0.0, -width_m / 2), (-depth_m, -width_m / 2),
                      (-depth_m, width_m / 2)):
        corners.append((x_m + c * fwd - s * left, y_m + s * fwd + c * left))
    return np.array([(*corners[i], *corners[(i + 1) % 4]) for i in range(4)])


def _facing(seg: FloatArray, x_m: float, y_m: float, angles_rad: FloatArray
            ) -> tuple[npt.NDArray[np.intp], FloatArray, FloatArray, FloatArray, FloatArray]:
    """The segments whose extent seen from the sensor meets the beams' arc: (their indices,
    and every segment's ends relative to the sensor: ax, ay, bx, by)."""
    ax, ay = seg[:, 0] - x_m, seg[:, 1] - y_m
    bx, by = seg[:, 2] - x_m, seg[:, 3] - y_m
    mid = float(np.arctan2(np.sin(angles_rad).mean(), np.cos(angles_rad).mean()))
    half = float(np.abs(_wrap(angles_rad - mid)).max()) + 1e-6
    a1 = _wrap(np.arctan2(ay, ax) - mid)
    a2 = _wrap(np.arctan2(by, bx) - mid)
    lo, hi = np.minimum(a1, a2), np.maximum(a1, a2)
    behind = hi - lo > math.pi  # the segment's extent wraps through the back
    keep = np.where(behind, (hi <= -math.pi + half) | (lo >= math.pi - half) | (half >= 1.5),
                    (hi >= -half) & (lo <= half))
    return np.flatnonzero(keep), ax, ay, bx, by


_CHUNK = 96
"""Segments intersected at once by ``cast_nearest_first``."""


def cast_nearest_first(seg: FloatArray, normal: FloatArray, x_m: float, y_m: float,
                       angles_rad: FloatArray, cos_grazing: float = 0.0) -> FloatArray:
    """As ``cast_segments``, meeting the segments nearest first, ``_CHUNK`` of them, then
    twice as many each time, and done with a beam once its hit is nearer than every segment
    left (the same ranges; of two
    segments hit at exactly the same distance, a corner, the nearer-listed one is taken)."""
    n = angles_rad.size
    out = np.full(n, math.inf)
    if seg.shape[0] == 0 or n == 0:
        return out
    idx, ax, ay, bx, by = _facing(seg, x_m, y_m, angles_rad)
    if idx.size == 0:
        return out
    ax, ay = ax[idx], ay[idx]
    ex, ey = bx[idx] - ax, by[idx] - ay
    length2 = ex * ex + ey * ey
    with np.errstate(divide="ignore", invalid="ignore"):
        along = np.clip(-(ax * ex + ay * ey) / length2, 0.0, 1.0)
    along = np.where(length2 > 0, along, 0.0)
    near = np.hypot(ax + along * ex, ay + along * ey)  # each segment's nearest point
    order = np.argsort(near, kind="stable")
    best_t = np.full(n, math.inf)
    best_seg = np.zeros(n, dtype=np.intp)
    open_beams = np.arange(n)
    cos_a, sin_a = np.cos(angles_rad), np.sin(angles_rad)
    start, size = 0, _CHUNK
    while start < order.size:
        part = order[start:start + size]
        dx = cos_a[open_beams][:, None]
        dy = sin_a[open_beams][:, None]
        pax, pay, pex, pey = ax[part], ay[part], ex[part], ey[part]
        denom = dx * pey - dy * pex
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (pax * pey - pay * pex) / denom
            u = (pax * dy - pay * dx) / denom
        hit = (np.abs(denom) > 1e-12) & (t > 0) & (u >= 0) & (u <= 1)
        t = np.where(hit, t, math.inf)
        k = t.argmin(axis=1)
        t_k = t[np.arange(open_beams.size), k]
        better = t_k < best_t[open_beams]
        best_t[open_beams[better]] = t_k[better]
        best_seg[open_beams[better]] = idx[part[k[better]]]
        start += size
        size *= 2  # beams still open look far: fewer, larger chunks
        if start >= order.size:
            break
        open_beams = open_beams[best_t[open_beams] > near[order[start]]]
        if open_beams.size == 0:
            break
    if cos_grazing > 0:
        nrm = normal[best_seg]
        incidence = np.abs(cos_a * nrm[:, 0] + sin_a * nrm[:, 1])
        best_t = np.where(incidence < cos_grazing, math.inf, best_t)
    out[:] = best_t
    return out


def cast_segments(seg: FloatArray, normal: FloatArray, x_m: float, y_m: float,
                  angles_rad: FloatArray, cos_grazing: float = 0.0) -> FloatArray:
    """Nearest hit of each beam (world angles) on the segments; inf for none or grazing."""
    n = angles_rad.size
    out = np.full(n, math.inf)
    if seg.shape[0] == 0 or n == 0:
        return out
    # Cull by angle: keep segments whose extent seen from the sensor meets the beams' arc.
    idx, ax, ay, bx, by = _facing(seg, x_m, y_m, angles_rad)
    if idx.size == 0:
        return out
    ax, ay = ax[idx], ay[idx]
    ex, ey = bx[idx] - ax, by[idx] - ay
    dx = np.cos(angles_rad)[:, None]
    dy = np.sin(angles_rad)[:, None]
    denom = dx * ey - dy * ex
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (ax * ey - ay * ex) / denom
        u = (ax * dy - ay * dx) / denom
    hit = (np.abs(denom) > 1e-12) & (t > 0) & (u >= 0) & (u <= 1)
    t = np.where(hit, t, math.inf)
    best = t.argmin(axis=1)
    rows = np.arange(n)
    dist = t[rows, best]
    if cos_grazing > 0:
        nrm = normal[idx][best]
        incidence = np.abs(dx[:, 0] * nrm[:, 0] + dy[:, 0] * nrm[:, 1])
        dist = np.where(incidence < cos_grazing, math.inf, dist)
    out[:] = dist
    return out


def cast_circles(circles: FloatArray, x_m: float, y_m: float, angles_rad: FloatArray
                 ) -> FloatArray:
    """Nearest hit of each beam on the circles (x, y, r); inf for none."""
    cx, cy, r = circles[:, 0] - x_m, circles[:, 1] - y_m, circles[:, 2]
    dx = np.cos(angles_rad)[:, None]
    dy = np.sin(angles_rad)[:, None]
    along = dx * cx + dy * cy
    across2 = cx * cx + cy * cy - along * along
    inside = r * r - across2
    with np.errstate(invalid="ignore"):
        t = along - np.sqrt(np.where(inside >= 0, inside, 0.0))
    ok = (inside >= 0) & (t > 0)
    nearest: FloatArray = np.where(ok, t, math.inf).min(axis=1)
    return nearest


def _wrap(a: FloatArray) -> FloatArray:
    wrapped: FloatArray = (a + math.pi) % (2 * math.pi) - math.pi
    return wrapped
