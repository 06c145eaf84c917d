"""A pose graph over key scans, optimised by SciPy's sparse nonlinear least squares.

Nodes are key-scan poses; an edge says where node ``j`` lies seen from node ``i`` (odometry or
a scan match between consecutive key scans, or a loop closure), with a standard deviation per
component. ``optimise`` minimises the sum of squared, whitened edge errors

    e = (R(theta_i)^T (t_j - t_i) - z_xy,  wrap(theta_j - theta_i - z_theta)) / sigma

over every pose but the first (held where it is: the map frame), with
``scipy.optimize.least_squares`` (trust-region reflective, LSMR on the sparse Jacobian that
this module writes out: six non-zeros per error row). A loop closure whose whitened error is
still large after a solve (it disagrees with the rest of the graph) is dropped and the graph
solved again: a robust loss (SciPy's Huber) converged far slower on the same graphs.

Why SciPy and not GTSAM's ``Pose2`` factors: both are maintained and both have wheels for
CPython 3.11 on x86_64 and on aarch64 (GTSAM 4.3.0, ~33 MB a wheel, checked with
``pip download``), but SciPy is a general numerical library that Debian and PyPI ship
everywhere the Pi image may be built, it is 30 MB less of compiled code that only this module
would use, and a site's graph (hundreds to a few thousand key scans) solves in well under a
second with a sparse trust-region solver. GTSAM's iSAM2 would pay off for incremental
re-solves on very long runs; the graph here is re-solved whole, so it is not needed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
import structlog
from scipy.optimize import least_squares
from scipy.sparse import csr_matrix

from behaviours.nav.icp import Pose

log = structlog.get_logger(__name__)
FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class Edge:
    i: int
    j: int
    measured: Pose
    """Node j's pose seen from node i."""
    sigma_m: float
    sigma_rad: float
    kind: str = "odometry"
    """``odometry``, ``match`` (consecutive key scans) or ``loop``."""


@dataclass(slots=True)
class PoseGraph:
    poses: list[Pose] = field(default_factory=list)
    edges: list[Edge] = field(default_factory=list)

    def add_node(self, pose: Pose) -> int:
        self.poses.append(pose)
        return len(self.poses) - 1

    def add_edge(self, edge: Edge) -> None:
        if not (0 <= edge.i < len(self.poses) and 0 <= edge.j < len(self.poses)):
            msg = f"edge {edge.i}->{edge.j}: no such node (graph has {len(self.poses)})"
            raise ValueError(msg)
        self.edges.append(edge)

    def loop_closures(self) -> int:
        return sum(1 for e in self.edges if e.kind == "loop")

    def optimise(self, *, max_loop_error: float = 5.0, max_evaluations: int = 50) -> float:
        """Re-place every node but the first (in place); returns the final cost (half the
        sum of squared whitened errors). Loop closures whose whitened error stays above
        ``max_loop_error`` (in sigmas, any component) are dropped and the graph re-solved."""
        cost = self._solve(max_evaluations)
        for _round in range(3):
            errors = np.abs(_Problem(self.poses, self.edges).residuals(
                np.asarray(self.poses[1:], dtype=np.float64).ravel())).reshape(-1, 3)
            bad = {k for k, e in enumerate(self.edges)
                   if e.kind == "loop" and float(errors[k].max()) > max_loop_error}
            if not bad:
                break
            log.info("mapping.loops_dropped", count=len(bad))
            self.edges = [e for k, e in enumerate(self.edges) if k not in bad]
            cost = self._solve(max_evaluations)
        return cost

    def _solve(self, max_evaluations: int) -> float:
        n = len(self.poses)
        if n < 2 or not self.edges:
            return 0.0
        problem = _Problem(self.poses, self.edges)
        x0 = np.asarray(self.poses[1:], dtype=np.float64).ravel()
        result = least_squares(problem.residuals, x0, jac=problem.jacobian, method="trf",
                               tr_solver="lsmr", tr_options={"atol": 1e-10, "btol": 1e-10},
                               max_nfev=max_evaluations)
        xs = result.x.reshape(-1, 3)
        self.poses[1:] = [(float(x), float(y), math.atan2(math.sin(t), math.cos(t)))
                          for x, y, t in xs]
        log.debug("mapping.graph_optimised", nodes=n, edges=len(self.edges),
                  loops=self.loop_closures(), cost=float(result.cost),
                  evaluations=int(result.nfev))
        return float(result.cost)


class _Problem:
    """The whitened edge errors and their sparse Jacobian over nodes 1..n-1."""

    def __init__(self, poses: list[Pose], edges: list[Edge]) -> None:
        self.first = np.asarray(poses[0], dtype=np.float64)
        self.n_vars = 3 * (len(poses) - 1)
        self.i = np.array([e.i for e in edges], dtype=np.intp)
        self.j = np.array([e.j for e in edges], dtype=np.intp)
        self.z = np.array([e.measured for e in edges], dtype=np.float64)
        self.w = np.array([(1 / e.sigma_m, 1 / e.sigma_m, 1 / e.sigma_rad) for e in edges])

    def _poses(self, x: FloatArray) -> FloatArray:
        return np.vstack((self.first[None, :], x.reshape(-1, 3)))

    def residuals(self, x: FloatArray) -> FloatArray:
        p = self._poses(x)
        pi, pj = p[self.i], p[self.j]
        c, s = np.cos(pi[:, 2]), np.sin(pi[:, 2])
        dx, dy = pj[:, 0] - pi[:, 0], pj[:, 1] - pi[:, 1]
        ex = c * dx + s * dy - self.z[:, 0]
        ey = -s * dx + c * dy - self.z[:, 1]
        et = pj[:, 2] - pi[:, 2] - self.z[:, 2]
        et = np.arctan2(np.sin(et), np.cos(et))
        out: FloatArray = (np.column_stack((ex, ey, et)) * self.w).ravel()
        return out

    def jacobian(self, x: FloatArray) -> csr_matrix:
        p = self._poses(x)
        pi, pj = p[self.i], p[self.j]
        c, s = np.cos(pi[:, 2]), np.sin(pi[:, 2])
        dx, dy = pj[:, 0] - pi[:, 0], pj[:, 1] - pi[:, 1]
        m = self.i.size
        zeros, ones = np.zeros(m), np.ones(m)
        # d(ex, ey, et) / d(xi, yi, ti) and / d(xj, yj, tj), one 3x3 block per edge.
        d_i = np.stack([
            np.stack([-c, -s, -s * dx + c * dy], axis=1),
            np.stack([s, -c, -c * dx - s * dy], axis=1),
            np.stack([zeros, zeros, -ones], axis=1)], axis=1)
        d_j = np.stack([
            np.stack([c, s, zeros], axis=1),
            np.stack([-s, c, zeros], axis=1),
            np.stack([zeros, zeros, ones], axis=1)], axis=1)
        d_i = d_i * self.w[:, :, None]
        d_j = d_j * self.w[:, :, None]
        rows = np.repeat(np.arange(3 * m).reshape(m, 3), 3, axis=1).reshape(m, 3, 3)
        blocks, cols, rws = [], [], []
        for node, block in ((self.i, d_i), (self.j, d_j)):
            keep = node > 0  # node 0 is held: no column
            col = 3 * (node[keep] - 1)
            cols.append((col[:, None, None] + np.arange(3)[None, None, :]).repeat(3, axis=1)
                        .ravel())
            rws.append(rows[keep].ravel())
            blocks.append(block[keep].ravel())
        return csr_matrix((np.concatenate(blocks), (np.concatenate(rws), np.concatenate(cols))),
                          shape=(3 * m, self.n_vars))
