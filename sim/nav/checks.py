"""The navigation success conditions, from the run's ``nav.*`` events.

``nav.pose`` events carry the estimate (``est_x_m``, ``est_y_m``, ``est_heading_deg``) and
the runner adds the simulator's true pose (``x_m``, ``y_m``, ``true_heading_deg``);
``nav.goal_reached`` carries the goal, and the true pose at that moment. Conditions
(``[success]`` keys):

- ``max_localisation_error_p95_m``, ``max_heading_error_p95_deg``: 95th percentile of the
  estimate's error against the true pose, over the samples while localised;
- ``min_pose_rate_hz``: poses published per second by the localisation service;
- ``goals_reached_within_m``: every goal of ``patrol.goals`` reached (true pose within this);
- ``divergence_within_s``: after the first ``body.teleport``, the robot reported a
  divergence (``localisation.diverged``) within this many seconds;
- ``relocalised_within_s``: after the first ``body.teleport``, the robot relocalised over the
  whole map (``nav.relocalised``) within this many seconds;
- ``no_pose_in_keepout`` (true): no true pose of the robot (every event carries it) lies in a
  cell of the keep-out mask the robot was given (``nav.zones``);
- ``speed_within_zone_limits`` (true): between consecutive ``nav.pose`` samples the robot's
  true speed is at most the speed mask's limit at both ends (``nav.zones``: the mask, Nav2's
  rule and the top speed percentages refer to).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from behaviours.nav.zones import SpeedRule, mask_values
from hal.occupancy_map import MapFileError, OccupancyMap, read_map_yaml
from sim.slice import CheckRun, Events


def pose_errors(events: list[dict[str, Any]]) -> tuple[list[float], list[float]]:
    """(position errors m, heading errors deg) of the localised ``nav.pose`` samples."""
    pos, head = [], []
    for e in events:
        if e.get("kind") != "nav.pose" or e.get("status") != "localised" \
                or "true_heading_deg" not in e:
            continue
        pos.append(math.hypot(e["est_x_m"] - e["x_m"], e["est_y_m"] - e["y_m"]))
        d = (e["est_heading_deg"] - e["true_heading_deg"] + 180.0) % 360.0 - 180.0
        head.append(abs(d))
    return pos, head


def pose_rate_hz(events: list[dict[str, Any]]) -> float | None:
    """Poses published per second between the first and the last ``nav.pose`` sample."""
    samples = [e for e in events if e.get("kind") == "nav.pose"]
    if len(samples) < 2:
        return None
    first, last = samples[0], samples[-1]
    span_s = float(last["t"]) - float(first["t"])
    if span_s <= 0:
        return None
    return (int(last["poses_published"]) - int(first["poses_published"])) / span_s


def p95(values: list[float]) -> float | None:
    return float(np.percentile(values, 95)) if values else None


def nav_figures(events: list[dict[str, Any]]) -> dict[str, Any]:
    """The figures the report's summary shows for a navigating robot (empty for others)."""
    out: dict[str, Any] = {}
    pos, head = pose_errors(events)
    if pos:
        out["localisation_error_p95_m"] = round(p95(pos) or 0.0, 4)
        out["heading_error_p95_deg"] = round(p95(head) or 0.0, 2)
    rate = pose_rate_hz(events)
    if rate is not None:
        out["pose_rate_hz"] = round(rate, 2)
    reached = [e for e in events if e.get("kind") == "nav.goal_reached"]
    if reached:
        out["goals_reached"] = len(reached)
        out["goal_error_max_m"] = round(max(_goal_error(e) for e in reached), 4)
    divergences = [e for e in events if e.get("kind") == "localisation.diverged"]
    if divergences:
        out["divergences"] = len(divergences)
    relocalised = [e for e in events if e.get("kind") == "nav.relocalised"]
    if relocalised:
        out["relocalisations"] = len(relocalised)
        out["relocalise_max_s"] = max(float(e["duration_s"]) for e in relocalised)
    if zones_of(events) is not None:
        out.update(zone_figures(events))
    return out


def _goal_error(e: dict[str, Any]) -> float:
    return math.hypot(e["goal_x_m"] - e["x_m"], e["goal_y_m"] - e["y_m"])


def nav_failures(success: dict[str, Any], events: list[dict[str, Any]],
                 goals: list[list[float]]) -> list[str]:
    """Each navigation condition of ``success`` (its extra keys) that does not hold."""
    reasons: list[str] = []
    pos, head = pose_errors(events)
    want = success.get("max_localisation_error_p95_m")
    if want is not None:
        got = p95(pos)
        if got is None:
            reasons.append("no localised nav.pose samples to judge the localisation error")
        elif got > float(want):
            reasons.append(f"localisation error p95 {got * 100:.1f} cm > "
                           f"{float(want) * 100:.1f} cm")
    want = success.get("max_heading_error_p95_deg")
    if want is not None:
        got = p95(head)
        if got is None:
            reasons.append("no localised nav.pose samples to judge the heading error")
        elif got > float(want):
            reasons.append(f"heading error p95 {got:.2f} deg > {float(want):g} deg")
    want = success.get("min_pose_rate_hz")
    if want is not None:
        rate = pose_rate_hz(events)
        if rate is None or rate < float(want):
            shown = "none" if rate is None else f"{rate:.1f} Hz"
            reasons.append(f"pose rate {shown} < {float(want):g} Hz")
    want = success.get("goals_reached_within_m")
    if want is not None:
        reasons += _goal_failures(float(want), events, goals)
    want = success.get("divergence_within_s")
    if want is not None:
        reasons += _after_kidnap(float(want), events, "localisation.diverged",
                                 "the kidnapping was never detected (no localisation.diverged "
                                 "event)", "the kidnapping was detected {:.1f} s after it")
    want = success.get("relocalised_within_s")
    if want is not None:
        reasons += _after_kidnap(float(want), events, "nav.relocalised",
                                 "the robot never relocalised after the kidnapping (no "
                                 "nav.relocalised event)",
                                 "the robot relocalised {:.1f} s after the kidnapping")
    if success.get("no_pose_in_keepout"):
        reasons += keepout_failures(events)
    if success.get("speed_within_zone_limits"):
        reasons += speed_failures(events)
    return reasons


def _goal_failures(within_m: float, events: list[dict[str, Any]],
                   goals: list[list[float]]) -> list[str]:
    reasons = []
    reached = [e for e in events if e.get("kind") == "nav.goal_reached"]
    for i, (gx, gy) in enumerate(goals):
        mine = [e for e in reached if e.get("index") == i]
        if not mine:
            reasons.append(f"goal {i} ({gx:.2f}, {gy:.2f}) never reached")
            continue
        worst = max(_goal_error(e) for e in mine)
        if worst > within_m:
            reasons.append(f"goal {i} ({gx:.2f}, {gy:.2f}) reached {worst * 100:.1f} cm off "
                           f"(true pose), more than {within_m * 100:.1f} cm")
    return reasons


def _after_kidnap(within_s: float, events: list[dict[str, Any]], kind: str, never: str,
                  late: str) -> list[str]:
    kidnaps = [e for e in events if e.get("kind") == "script"
               and e.get("action") == "body.teleport"]
    if not kidnaps:
        return [f"{kind}: the script never teleported the robot"]
    t0 = float(kidnaps[0]["t"])
    seen = [float(e["t"]) for e in events if e.get("kind") == kind and float(e["t"]) >= t0]
    if not seen:
        return [never]
    if seen[0] - t0 > within_s:
        return [f"{late.format(seen[0] - t0)}, more than {within_s:g} s"]
    return []


def zones_of(events: list[dict[str, Any]]) -> dict[str, Any] | None:
    """The ``nav.zones`` event (the masks a robot was given), if any."""
    return next((e for e in events if e.get("kind") == "nav.zones"), None)


def _mask(zones: dict[str, Any] | None, key: str) -> OccupancyMap | str | None:
    """The mask the event names, None if none, or why it cannot be read."""
    path = None if zones is None else zones.get(key)
    if not path:
        return None
    try:
        return read_map_yaml(str(path))
    except MapFileError as exc:
        return str(exc)


def keepout_failures(events: list[dict[str, Any]]) -> list[str]:
    """Every true pose in a keep-out cell (the first few, and how many)."""
    mask = _mask(zones_of(events), "keepout_file")
    if mask is None:
        return ["no_pose_in_keepout: the robot was given no keep-out mask (no nav.zones "
                "event with a keepout_file)"]
    if isinstance(mask, str):
        return [f"no_pose_in_keepout: {mask}"]
    poses = [e for e in events if "x_m" in e and "y_m" in e]
    if not poses:
        return []
    xy = np.array([[float(e["x_m"]), float(e["y_m"])] for e in poses])
    inside = mask_values(mask, xy[:, 0], xy[:, 1]) >= 100
    if not inside.any():
        return []
    first = [poses[i] for i in np.flatnonzero(inside)[:3]]
    shown = ", ".join(f"({e['x_m']:.2f}, {e['y_m']:.2f}) at {float(e['t']):.1f} s"
                      for e in first)
    return [f"{int(inside.sum())} true pose(s) in a keep-out cell: {shown}"]


def zone_speeds(events: list[dict[str, Any]]
                ) -> list[tuple[float, float, float | None]] | str:
    """(time, true speed, the mask's lower limit at the two ends in m/s or None) between
    consecutive ``nav.pose`` samples of each robot; or why there are none."""
    zones = zones_of(events)
    mask = _mask(zones, "speed_file")
    if mask is None or zones is None:
        return "the robot was given no speed mask (no nav.zones event with a speed_file)"
    if isinstance(mask, str):
        return mask
    rule = SpeedRule(zones.get("speed_type") == "percent", float(zones["speed_base"]),
                     float(zones["speed_multiplier"]))
    top = float(zones["speed_top_mps"])
    out: list[tuple[float, float, float | None]] = []
    by_robot: dict[str, list[dict[str, Any]]] = {}
    for e in events:
        if e.get("kind") == "nav.pose":
            by_robot.setdefault(str(e.get("robot", "")), []).append(e)
    for samples in by_robot.values():
        if len(samples) < 2:
            continue
        xy = np.array([[float(e["x_m"]), float(e["y_m"])] for e in samples])
        t = np.array([float(e["t"]) for e in samples])
        limits = rule.limits(mask_values(mask, xy[:, 0], xy[:, 1]))
        for i in range(1, len(samples)):
            dt = t[i] - t[i - 1]
            if dt <= 0:
                continue
            speed = float(math.hypot(*(xy[i] - xy[i - 1]))) / dt
            ends = limits[i - 1:i + 1]
            limit = None if np.all(np.isnan(ends)) else rule.mps(float(np.nanmin(ends)), top)
            out.append((float(t[i]), speed, limit))
    return out


def speed_failures(events: list[dict[str, Any]]) -> list[str]:
    """Each stretch between pose samples driven faster than the zone's limit (the worst)."""
    speeds = zone_speeds(events)
    if isinstance(speeds, str):
        return [f"speed_within_zone_limits: {speeds}"]
    over = [(t, v, lim) for t, v, lim in speeds if lim is not None and v > lim + 1e-9]
    if not over:
        return []
    t, v, lim = max(over, key=lambda o: o[1] - (o[2] or 0.0))
    return [f"{len(over)} stretch(es) faster than the speed zone allows: worst "
            f"{v:.3f} m/s where the limit is {lim:.3f} m/s, at {t:.1f} s"]


def zone_figures(events: list[dict[str, Any]]) -> dict[str, Any]:
    """The fastest speed in a limited zone, as a share of its limit."""
    speeds = zone_speeds(events)
    if isinstance(speeds, str):
        return {}
    ratios = [v / lim for _t, v, lim in speeds if lim]
    return {"zone_speed_max_pct_of_limit": round(100 * max(ratios), 1)} if ratios else {}


NAV_SUCCESS_KEYS = ("max_localisation_error_p95_m", "max_heading_error_p95_deg",
                    "min_pose_rate_hz", "goals_reached_within_m", "divergence_within_s",
                    "relocalised_within_s", "no_pose_in_keepout", "speed_within_zone_limits")


@dataclass(frozen=True, slots=True)
class NavCheck:
    """The navigation conditions, for a robot that localises and drives to goals.

    ``goals_key``: the ``section.key`` of the scenario's config that lists the goals
    ``goals_reached_within_m`` judges (None: the robot is given none)."""

    goals_key: str | None = None
    keys: tuple[str, ...] = NAV_SUCCESS_KEYS

    def failures(self, run: CheckRun) -> list[str]:
        goals: list[list[float]] = []
        if self.goals_key is not None:
            section, _, key = self.goals_key.partition(".")
            goals = run.config.get(section, {}).get(key, [])
        return nav_failures(run.extra, run.events, goals)

    def figures(self, events: Events) -> dict[str, Any]:
        return nav_figures(events)
