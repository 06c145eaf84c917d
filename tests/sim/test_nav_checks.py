"""The navigation success conditions, on hand-made events."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

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

    def test_relocalised_within(self) -> None:
        """After a teleport the robot must find itself again (nav.relocalised) in time."""
        kidnap = {"t": 10.0, "kind": "script", "action": "body.teleport"}
        late = {"t": 45.0, "kind": "nav.relocalised", "ok": True, "duration_s": 30.0}
        assert nav_failures({"relocalised_within_s": 30.0}, [kidnap, late], []) == [
            "the robot relocalised 35.0 s after the kidnapping, more than 30 s"]
        soon = {"t": 20.0, "kind": "nav.relocalised", "ok": True, "duration_s": 5.0}
        assert nav_failures({"relocalised_within_s": 30.0}, [kidnap, soon], []) == []
        assert nav_figures([kidnap, soon])["relocalise_max_s"] == 5.0


class TestZoneChecks:
    @staticmethod
    def _zones(tmp_path: Path) -> dict[str, Any]:
        """A 4 x 2 m site: keep-out cells at x 1-2, a 50 % zone at x 3-4 (Nav2's rule)."""
        cells_keepout = np.full((40, 80), 254, dtype=np.uint8)
        cells_keepout[:, 20:40] = 0
        cells_speed = np.full((40, 80), 255, dtype=np.uint8)
        cells_speed[:, 60:80] = 127  # occ 0.5 -> value 50 in scale mode
        for name, pixels, mode in (("keepout", cells_keepout, "trinary"),
                                   ("speed", cells_speed, "scale")):
            (tmp_path / f"{name}.pgm").write_bytes(b"P5\n80 40\n255\n" + pixels.tobytes())
            thresholds = ("occupied_thresh: 0.65\nfree_thresh: 0.25\n" if mode == "trinary"
                          else "occupied_thresh: 1.0\nfree_thresh: 0.0\n")
            (tmp_path / f"{name}.yaml").write_text(
                f"image: {name}.pgm\nmode: {mode}\nresolution: 0.05\norigin: [0, 0, 0]\n"
                f"negate: 0\n{thresholds}")
        return {"t": 0.0, "kind": "nav.zones", "keepout_file": str(tmp_path / "keepout.yaml"),
                "speed_file": str(tmp_path / "speed.yaml"), "speed_type": "percent",
                "speed_base": 100.0, "speed_multiplier": -1.0, "speed_top_mps": 0.2}

    def test_a_true_pose_in_a_keepout_cell_fails(self, tmp_path: Path) -> None:
        """Every event's true pose is judged against the keep-out mask."""
        zones = self._zones(tmp_path)
        ok = [zones, {"t": 1.0, "kind": "nav.pose", "x_m": 0.5, "y_m": 1.0}]
        assert nav_failures({"no_pose_in_keepout": True}, ok, []) == []
        bad = [*ok, {"t": 2.0, "kind": "transition", "x_m": 1.5, "y_m": 1.0}]
        assert nav_failures({"no_pose_in_keepout": True}, bad, []) == [
            "1 true pose(s) in a keep-out cell: (1.50, 1.00) at 2.0 s"]
        assert "no keep-out mask" in nav_failures({"no_pose_in_keepout": True}, ok[1:], [])[0]

    def test_faster_than_a_zone_allows_fails(self, tmp_path: Path) -> None:
        """0.09 m/s in the 50 % zone (0.1 m/s) holds; 0.12 m/s does not; outside, any."""
        zones = self._zones(tmp_path)

        def pose(t: float, x: float) -> dict[str, Any]:
            return {"t": t, "kind": "nav.pose", "x_m": x, "y_m": 1.0, "poses_published": 0}

        slow = [zones, pose(0.0, 3.2), pose(1.0, 3.29)]
        assert nav_failures({"speed_within_zone_limits": True}, slow, []) == []
        assert nav_figures(slow)["zone_speed_max_pct_of_limit"] == 90.0
        outside = [zones, pose(0.0, 0.2), pose(1.0, 0.8)]
        assert nav_failures({"speed_within_zone_limits": True}, outside, []) == []
        fast = [zones, pose(0.0, 3.2), pose(1.0, 3.32)]
        assert nav_failures({"speed_within_zone_limits": True}, fast, []) == [
            "1 stretch(es) faster than the speed zone allows: worst 0.120 m/s where the limit "
            "is 0.100 m/s, at 1.0 s"]
