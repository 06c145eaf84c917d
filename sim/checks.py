"""A scenario's success conditions, checked against what happened in a run."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from sim.registry import distinct, slice_of
from sim.scenario import Scenario
from sim.slice import CheckRun, SuccessCheck
from sim.world.body import DiffDriveBody


@dataclass
class RobotRecord:
    """What the runner saw of one robot: the states it passed through, estops, its body."""

    name: str
    body: DiffDriveBody
    states_seen: list[str] = field(default_factory=list)
    estops: int = 0
    state: str = "boot"
    cross_track_sum_m: float = 0.0
    cross_track_samples: int = 0

    def saw(self, state: str) -> bool:
        """True if the robot was in ``state`` or a state inside it."""
        return any(s == state or s.startswith(state + ".") for s in self.states_seen)

    @property
    def mean_cross_track_m(self) -> float | None:
        if self.cross_track_samples == 0:
            return None
        return self.cross_track_sum_m / self.cross_track_samples


def finished(scenario: Scenario, robots: dict[str, RobotRecord]) -> bool:
    """True once every robot has seen its required states and sits in the final state."""
    success = scenario.success
    if success.final_state is None:
        return False
    return all(
        r.state in success.final_states and all(r.saw(s) for s in success.states_reached)
        for r in robots.values()
    )


def failures(scenario: Scenario, robots: dict[str, RobotRecord], elapsed_s: float,
             extra: list[str] | None = None,
             events: list[dict[str, Any]] | None = None, *, paced: bool = False) -> list[str]:
    """Every success condition that does not hold, as a sentence; empty when all hold
    (``paced``: the run followed the wall clock, so its timers may be a little late)."""
    success = scenario.success
    reasons: list[str] = list(extra or [])
    many = len(robots) > 1
    for name, r in robots.items():
        who = f"{name}: " if many else ""
        for state in success.states_reached:
            if not r.saw(state):
                reasons.append(f"{who}never reached state {state}")
        if success.final_state is not None and r.state not in success.final_states:
            reasons.append(f"{who}ended in state {r.state}, expected "
                           f"{' or '.join(success.final_states)}")
        if success.no_estop and r.estops:
            reasons.append(f"{who}went to estop {r.estops} time(s)")
        if success.no_collisions and r.body.collisions:
            c = r.body.collisions[0]
            reasons.append(f"{who}hit a wall {len(r.body.collisions)} time(s), first at "
                           f"t={c.t_s:.1f} s ({c.x_m:.2f}, {c.y_m:.2f})")
        if success.max_cross_track_m is not None and r.mean_cross_track_m is not None \
                and r.mean_cross_track_m > success.max_cross_track_m:
            reasons.append(f"{who}mean cross-track error {r.mean_cross_track_m * 100:.1f} cm "
                           f"> {success.max_cross_track_m * 100:.1f} cm")
    for pose in success.final_poses:
        body = robots[pose.robot].body
        off = body.pose.distance_to(pose.x_m, pose.y_m)
        if off > pose.tolerance_m:
            who = f"{pose.robot}: " if many else ""
            reasons.append(f"{who}ended {off * 100:.1f} cm from ({pose.x_m:.2f}, {pose.y_m:.2f})"
                           f", tolerance {pose.tolerance_m * 100:.1f} cm")
    reasons += _arrival_failures(scenario, events or [])
    run = CheckRun(success.extra, events or [], scenario.config,
                   [r.body for r in robots.values()], paced)
    for check in robot_checks(scenario):
        reasons += check.failures(run)
    for want in success.extra.get("final_rooms", []):
        record = robots.get(str(want.get("robot")))
        if record is None:
            reasons.append(f"final_rooms: no robot named {want.get('robot')!r}")
            continue
        where = record.body.pose
        room = scenario.world.room_at(where.x_m, where.y_m)
        if room != want.get("room"):
            reasons.append(f"{record.name} ended in {room or 'no room'} "
                           f"({where.x_m:.2f}, {where.y_m:.2f}), expected {want.get('room')}")
    if elapsed_s >= success.time_limit_s and not finished(scenario, robots) \
            and success.final_state is not None:
        reasons.append(f"time limit of {success.time_limit_s:g} s reached")
    return reasons


def summary_figures(robots: dict[str, RobotRecord], scenario: Scenario | None = None,
                    events: list[dict[str, Any]] | None = None) -> dict[str, Any]:
    """Each robot's figures; ``arrival_<room>_m``: how far from that room's beacon it was
    when it first reported arriving there."""
    out: dict[str, Any] = {}
    checks = robot_checks(scenario) if scenario is not None and events else []
    for name, r in robots.items():
        pose = r.body.pose
        fig: dict[str, Any] = {
            "distance_m": round(r.body.distance_m, 3),
            "final_x_m": round(pose.x_m, 4), "final_y_m": round(pose.y_m, 4),
            "battery_pct": round(r.body.charge_pct, 2),
        }
        # Where the scenario allows contact (a vacuum cleans by bumping into things) it is a
        # bump by design, not a collision.
        designed = scenario is not None and not scenario.success.no_collisions
        fig["bumps" if designed else "collisions"] = len(r.body.collisions)
        if r.mean_cross_track_m is not None:
            fig["mean_cross_track_cm"] = round(r.mean_cross_track_m * 100, 2)
        if scenario is not None and scenario.world.dock is not None:
            lateral_m, heading_rad = dock_error(r.body)
            fig["dock_lateral_cm"] = round(lateral_m * 100, 2)
            fig["dock_heading_deg"] = round(math.degrees(heading_rad), 2)
        if scenario is not None and events:
            mine = [e for e in events if e.get("robot", name) == name] if len(robots) > 1 \
                else events
            fig.update(_arrival_figures(scenario, mine))
            for check in checks:
                fig.update(check.figures(mine))
        out[name] = fig
    return out


def robot_checks(scenario: Scenario) -> list[SuccessCheck]:
    """The success checks of the scenario's robots' simulator slices, each once."""
    return distinct(c for p in scenario.profiles for c in slice_of(p).checks)


def dock_error(body: DiffDriveBody) -> tuple[float, float]:
    """How far a robot is from sitting docked: sideways off the dock's axis (m) and its
    heading off the docked heading (rad), signed; (inf, inf) in a world without a dock."""
    dock = body.world.dock
    if dock is None:
        return math.inf, math.inf
    pose, docked = body.pose, dock.docked_pose(body.params.radius_m)
    _, left_m = dock.face_depth_m(pose.x_m, pose.y_m)
    heading = math.atan2(math.sin(pose.heading_rad - docked.heading_rad),
                         math.cos(pose.heading_rad - docked.heading_rad))
    return left_m, heading


def _arrival_figures(scenario: Scenario, events: list[dict[str, Any]]) -> dict[str, float]:
    out: dict[str, float] = {}
    for e in events:
        room = e.get("room")
        if e.get("kind") != "arrival" or f"arrival_{room}_m" in out or "x_m" not in e:
            continue
        off = _beacon_distance_m(scenario, str(room), e)
        if off is not None:
            out[f"arrival_{room}_m"] = round(off, 2)
    return out


def _beacon_distance_m(scenario: Scenario, room: str, event: dict[str, Any]) -> float | None:
    """How far the event's position is from the nearest beacon of ``room`` (None: none)."""
    beacons = [b for b in scenario.world.beacons if b.room == room]
    if not beacons:
        return None
    return min(math.hypot(event["x_m"] - b.x_m, event["y_m"] - b.y_m) for b in beacons)


def _arrival_failures(scenario: Scenario, events: list[dict[str, Any]]) -> list[str]:
    """``arrivals = [{ room, within_m }]``: the robot stopped by that room's beacon."""
    reasons = []
    for want in scenario.success.extra.get("arrivals", []):
        room, within = str(want.get("room")), float(want.get("within_m", 0.5))
        arrivals = [e for e in events if e.get("kind") == "arrival" and e.get("room") == room]
        off = _beacon_distance_m(scenario, room, arrivals[0]) if arrivals else None
        if not any(b.room == room for b in scenario.world.beacons):
            reasons.append(f"arrivals: no beacon in room {room} in the world")
        elif off is None:
            reasons.append(f"never arrived at room {room}")
        elif off > within:
            reasons.append(f"arrived at room {room} {off:.2f} m from its beacon, "
                           f"more than {within:g} m")
    return reasons
