"""Point-to-line ICP against wall segments: the polish after a correlative scan match.

Each scan point is paired with the closest point on the nearest wall; pairs farther than a
gate are dropped (unmapped furniture, people, outliers) and the gate shrinks as the fit
converges. The pose increment minimises the squared distances along the walls' normals (a
Gauss-Newton step of the point-to-line error, as in Censi's PLICP without the closed form);
a Huber weight keeps a few wrong pairs from pulling the pose.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
Pose = tuple[float, float, float]


@dataclass(frozen=True, slots=True)
class Walls:
    """Wall segments (M, 4) with what ICP needs of them precomputed."""

    start: FloatArray
    direction: FloatArray
    length: FloatArray
    normal: FloatArray

    @classmethod
    def of(cls, segments: FloatArray) -> Walls:
        segs = np.asarray(segments, dtype=np.float64).reshape(-1, 4)
        start = segs[:, :2]
        delta = segs[:, 2:] - start
        length = np.hypot(delta[:, 0], delta[:, 1])
        keep = length > 1e-9
        start, delta, length = start[keep], delta[keep], length[keep]
        direction = delta / length[:, None]
        normal = np.stack([-direction[:, 1], direction[:, 0]], axis=1)
        return cls(start, direction, length, normal)

    def nearest(self, points: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """For each point (N, 2): the distance to the nearest wall, the closest point on it,
        and that wall's unit normal."""
        sx, sy = self.start[:, 0], self.start[:, 1]
        dx, dy = self.direction[:, 0], self.direction[:, 1]
        rx = points[:, 0:1] - sx
        ry = points[:, 1:2] - sy
        t = np.clip(rx * dx + ry * dy, 0.0, self.length)
        gx = rx - t * dx
        gy = ry - t * dy
        dist2 = gx * gx + gy * gy
        best = np.argmin(dist2, axis=1)
        rows = np.arange(points.shape[0])
        tb = t[rows, best]
        closest = np.stack([sx[best] + tb * dx[best], sy[best] + tb * dy[best]], axis=1)
        return (np.sqrt(dist2[rows, best]), closest, self.normal[best])


def transform(points: FloatArray, pose: Pose) -> FloatArray:
    """Robot-frame points (N, 2) placed at a map-frame pose."""
    x, y, theta = pose
    c, s = math.cos(theta), math.sin(theta)
    out: FloatArray = np.empty_like(points)
    out[:, 0] = x + c * points[:, 0] - s * points[:, 1]
    out[:, 1] = y + s * points[:, 0] + c * points[:, 1]
    return out


def icp(points: FloatArray, walls: Walls, pose: Pose, *, gate_m: float = 0.20,
        final_gate_m: float = 0.05, iterations: int = 15, huber_m: float = 0.02) -> Pose:
    """The pose that lays ``points`` (robot frame) best onto the walls, starting at ``pose``."""
    x, y, theta = pose
    if points.shape[0] < 3 or walls.start.shape[0] == 0:
        return pose
    for i in range(iterations):
        gate = max(final_gate_m, gate_m * (1.0 - i / max(1, iterations // 2)))
        world = transform(points, (x, y, theta))
        dist, closest, normal = walls.nearest(world)
        use = dist < gate
        if np.count_nonzero(use) < 3:
            break
        p, q, n = world[use], closest[use], normal[use]
        residual = np.einsum("nk,nk->n", p - q, n)
        weight = np.where(np.abs(residual) <= huber_m, 1.0,
                          huber_m / np.maximum(np.abs(residual), 1e-12))
        arm = p - np.array([x, y])
        jac = np.stack([n[:, 0], n[:, 1], n[:, 1] * arm[:, 0] - n[:, 0] * arm[:, 1]], axis=1)
        h = jac.T @ (jac * weight[:, None])
        g = jac.T @ (weight * residual)
        try:
            step = -np.linalg.solve(h + np.eye(3) * 1e-9, g)
        except np.linalg.LinAlgError:
            break
        dx, dy, dtheta = (float(v) for v in step)
        # The rotation is about the robot's position: move it, then turn the arms.
        x, y, theta = x + dx, y + dy, theta + dtheta
        if math.hypot(dx, dy) < 1e-5 and abs(dtheta) < 1e-5 and gate <= final_gate_m:
            break
    return (x, y, math.atan2(math.sin(theta), math.cos(theta)))


def wall_score(points: FloatArray, walls: Walls, pose: Pose, sigma_m: float) -> float:
    """Mean over the points of exp(-d^2 / 2 sigma^2), d the distance to the nearest wall:
    1 when every point lies on a wall, about the share of points on walls otherwise."""
    if points.shape[0] == 0 or walls.start.shape[0] == 0:
        return 0.0
    dist, _closest, _normal = walls.nearest(transform(points, pose))
    return float(np.mean(np.exp(-(dist * dist) / (2 * sigma_m * sigma_m))))


def through_walls(points: FloatArray, walls: Walls, pose: Pose, slack_m: float = 0.10
                  ) -> float:
    """The share of beams that would have passed through a mapped wall to reach their point
    (the last ``slack_m`` of each beam not counted: noise, a point on the wall itself).

    Unmapped things (furniture, people) and outliers only ever shorten beams, so at the true
    pose this is near 0; a wrong pose that lays furniture onto walls sees through walls.
    """
    if points.shape[0] == 0 or walls.start.shape[0] == 0:
        return 0.0
    world = transform(points, pose)
    cx, cy = pose[0], pose[1]
    vx, vy = world[:, 0] - cx, world[:, 1] - cy
    length = np.maximum(np.hypot(vx, vy), 1e-9)
    keep = np.maximum(length - slack_m, 0.0) / length
    ex, ey = cx + vx * keep, cy + vy * keep
    ax, ay = walls.start[:, 0], walls.start[:, 1]
    bx = ax + walls.direction[:, 0] * walls.length
    by = ay + walls.direction[:, 1] * walls.length
    # Beam (c -> e) and wall (a -> b) cross when each one's ends lie on both sides of the other.
    d1 = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    d2 = (bx - ax) * (ey[:, None] - ay) - (by - ay) * (ex[:, None] - ax)
    d3 = (ex[:, None] - cx) * (ay - cy) - (ey[:, None] - cy) * (ax - cx)
    d4 = (ex[:, None] - cx) * (by - cy) - (ey[:, None] - cy) * (bx - cx)
    crossed = ((d1 * d2) < 0) & ((d3 * d4) < 0)
    return float(np.mean(np.any(crossed, axis=1)))
