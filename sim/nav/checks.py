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
  divergence (``localisation.diverged``) within this many seconds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

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
        reasons += _divergence_failures(float(want), events)
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


def _divergence_failures(within_s: float, events: list[dict[str, Any]]) -> list[str]:
    kidnaps = [e for e in events if e.get("kind") == "script"
               and e.get("action") == "body.teleport"]
    if not kidnaps:
        return ["divergence_within_s: the script never teleported the robot"]
    t0 = float(kidnaps[0]["t"])
    seen = [float(e["t"]) for e in events
            if e.get("kind") == "localisation.diverged" and float(e["t"]) >= t0]
    if not seen:
        return ["the kidnapping was never detected (no localisation.diverged event)"]
    if seen[0] - t0 > within_s:
        return [f"the kidnapping was detected {seen[0] - t0:.1f} s after it, "
                f"more than {within_s:g} s"]
    return []


NAV_SUCCESS_KEYS = ("max_localisation_error_p95_m", "max_heading_error_p95_deg",
                    "min_pose_rate_hz", "goals_reached_within_m", "divergence_within_s")


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
