"""The pose graph: its Jacobian, what a loop closure does, a wrong loop closure dropped."""

from __future__ import annotations

import math

import numpy as np

from behaviours.nav.icp import Pose
from behaviours.nav.mapping.pose_graph import Edge, PoseGraph, _Problem
from behaviours.nav.mapping.scan import between, compose


def _circle(n: int) -> list[Pose]:
    poses: list[Pose] = [(0.0, 0.0, 0.0)]
    for _ in range(n):
        poses.append(compose(poses[-1], (0.5, 0.0, 2 * math.pi / n)))
    return poses


def _drifting_graph(true: list[Pose], seed: int = 0) -> PoseGraph:
    rng = np.random.default_rng(seed)
    graph = PoseGraph()
    graph.add_node(true[0])
    for k in range(1, len(true)):
        z = between(true[k - 1], true[k])
        noisy = (z[0] + rng.normal(0, 0.02), z[1] + rng.normal(0, 0.02),
                 z[2] + rng.normal(0, 0.01))
        graph.add_node(compose(graph.poses[-1], noisy))
        graph.add_edge(Edge(k - 1, k, noisy, 0.02, 0.01))
    return graph


def _worst_m(a: list[Pose], b: list[Pose]) -> float:
    return max(math.hypot(p[0] - q[0], p[1] - q[1]) for p, q in zip(a, b, strict=True))


class TestPoseGraph:
    def test_the_jacobian_is_the_derivative_of_the_errors(self) -> None:
        """The analytic sparse Jacobian agrees with central differences."""
        graph = _drifting_graph(_circle(12))
        graph.add_edge(Edge(0, 12, (0.0, 0.0, 0.0), 0.01, 0.01, "loop"))
        problem = _Problem(graph.poses, graph.edges)
        x = np.asarray(graph.poses[1:], dtype=np.float64).ravel()
        x = x + np.random.default_rng(1).normal(0, 0.1, x.size)
        analytic = problem.jacobian(x).toarray()
        numeric = np.zeros_like(analytic)
        for col in range(x.size):
            d = np.zeros_like(x)
            d[col] = 1e-6
            numeric[:, col] = (problem.residuals(x + d) - problem.residuals(x - d)) / 2e-6
        assert np.abs(analytic - numeric).max() < 1e-5

    def test_a_loop_closure_pulls_the_drifted_circle_back(self) -> None:
        """Odometry drifts round a circle; the edge saying the end is the start fixes it."""
        true = _circle(40)
        graph = _drifting_graph(true)
        before = _worst_m(graph.poses, true)
        graph.add_edge(Edge(0, 40, between(true[0], true[40]), 0.01, 0.005, "loop"))
        graph.optimise()
        assert _worst_m(graph.poses, true) < before / 2
        assert graph.poses[0] == true[0]  # the first node holds the frame

    def test_a_loop_closure_that_disagrees_with_everything_is_dropped(self) -> None:
        """A wrong loop edge (2 m off, 1 cm sigma) is dropped and the odometry kept."""
        true = _circle(20)
        graph = _drifting_graph(true)
        odometry_only = list(graph.poses)
        graph.add_edge(Edge(0, 10, (2.0, 0.0, 0.0), 0.01, 0.005, "loop"))
        graph.optimise()
        assert graph.loop_closures() == 0
        assert _worst_m(graph.poses, odometry_only) < 1e-3
