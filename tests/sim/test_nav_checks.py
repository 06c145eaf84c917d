"""The navigation success conditions, on hand-made events."""

from __future__ import annotations

from typing import Any

from sim.nav.checks import nav_failures, nav_figures, pose_rate_hz


def _pose(t: float, err_m: float, err_deg: float = 0.0, n: int = 0,
          status: str = "localised") -> dict[str, Any]:
    return {"t": t, "kind": "nav.pose", "est_x_m": 1.0 + err_m, "est_y_m": 2.0,
            "est_heading_deg": 10.0 + err_deg, "x_m": 1.0, "y_m": 2.0,
            "true_heading_deg": 10.0, "status": status, "poses_published": n}


class TestNavChecks:
    def test_p95_of_localised_samples_only(self) -> None:
        """The p95 counts localised samples; a diverged one far off does not."""
        events = [_pose(i * 0.5, 0.01, 1.0, i * 10) for i in range(40)]
        events.append(_pose(30.0, 2.0, 90.0, 600, status="diverged"))
        assert nav_failures({"max_localisation_error_p95_m": 0.05,
                             "max_heading_error_p95_deg": 3.0}, events, []) == []
        assert nav_figures(events)["localisation_error_p95_m"] == 0.01

    def test_large_errors_fail_with_the_figure(self) -> None:
        """Errors over the limit fail, saying the figure and the limit."""
        events = [_pose(i * 0.5, 0.08, 5.0, i * 10) for i in range(10)]
        reasons = nav_failures({"max_localisation_error_p95_m": 0.05,
                                "max_heading_error_p95_deg": 3.0}, events, [])
        assert reasons == ["localisation error p95 8.0 cm > 5.0 cm",
                           "heading error p95 5.00 deg > 3 deg"]

    def test_heading_error_wraps(self) -> None:
        """179 deg against -179 deg is 2 deg apart."""
        e = _pose(0.0, 0.0)
        e["est_heading_deg"], e["true_heading_deg"] = 179.0, -179.0
        assert nav_failures({"max_heading_error_p95_deg": 3.0}, [e], []) == []

    def test_pose_rate(self) -> None:
        """Poses published over the span of the samples; below the minimum fails."""
        events = [_pose(i * 1.0, 0.0, n=i * 8) for i in range(5)]
        assert pose_rate_hz(events) == 8.0
        assert nav_failures({"min_pose_rate_hz": 10.0}, events, []) == [
            "pose rate 8.0 Hz < 10 Hz"]

    def test_goals_reached_within(self) -> None:
        """Every goal must have a nav.goal_reached within the distance (true pose)."""
        reached = [{"t": 1.0, "kind": "nav.goal_reached", "index": 0, "goal_x_m": 1.0,
                    "goal_y_m": 1.0, "x_m": 1.05, "y_m": 1.0},
                   {"t": 2.0, "kind": "nav.goal_reached", "index": 1, "goal_x_m": 2.0,
                    "goal_y_m": 1.0, "x_m": 2.0, "y_m": 1.2}]
        goals = [[1.0, 1.0], [2.0, 1.0], [3.0, 1.0]]
        reasons = nav_failures({"goals_reached_within_m": 0.1}, reached, goals)
        assert reasons == ["goal 1 (2.00, 1.00) reached 20.0 cm off (true pose), more than "
                           "10.0 cm", "goal 2 (3.00, 1.00) never reached"]

    def test_divergence_within(self) -> None:
        """After a teleport the divergence must be reported in time."""
        kidnap = {"t": 10.0, "kind": "script", "action": "body.teleport"}
        late = {"t": 25.0, "kind": "localisation.diverged"}
        assert nav_failures({"divergence_within_s": 10.0}, [kidnap, late], []) == [
            "the kidnapping was detected 15.0 s after it, more than 10 s"]
        soon = {"t": 12.0, "kind": "localisation.diverged"}
        assert nav_failures({"divergence_within_s": 10.0}, [kidnap, soon], []) == []
        assert nav_failures({"divergence_within_s": 10.0}, [kidnap], []) == [
            "the kidnapping was never detected (no localisation.diverged event)"]
