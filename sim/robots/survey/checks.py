"""The survey's success conditions: the saved map against the world's true cells, and the
optimised key-scan poses against the simulator's true ones.

``mapping.key_scan`` events carry each key scan's number and, added by the runner, the true
pose of that moment (the robot stands still through a key scan); the last ``mapping.saved``
carries the saved map's YAML and every key scan's optimised pose. Conditions (``[success]``):

- ``map_occupied_near_wall_pct``: of the saved map's occupied cells, at least this many per
  cent lie within one cell of a true wall (the world's map);
- ``map_free_truly_free_pct``: of its free cells, at least this many per cent are truly free;
- ``max_relation_error_m`` / ``max_relation_error_deg``: the relation error (Kümmerle et al.
  2009) over all pairs of key scans, mean translation and rotation, at most these;
- ``min_map_key_scans``: the map holds at least this many key scans.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from behaviours.nav.mapping.metrics import map_quality, relation_error
from hal.occupancy_map import MapFileError, read_map_yaml
from sim.slice import CheckRun, Events

KEYS = ("map_occupied_near_wall_pct", "map_free_truly_free_pct", "max_relation_error_m",
        "max_relation_error_deg", "min_map_key_scans")


def _saved(events: Events) -> dict[str, Any] | None:
    saved = [e for e in events if e.get("kind") == "mapping.saved"]
    return saved[-1] if saved else None


def key_pose_pairs(events: Events) -> tuple[list[tuple[float, float, float]],
                                            list[tuple[float, float, float]]]:
    """(estimated, true) poses of the key scans the saved map holds."""
    saved = _saved(events)
    if saved is None:
        return [], []
    truth = {int(e["key"]): (float(e["x_m"]), float(e["y_m"]),
                             math.radians(float(e["true_heading_deg"])))
             for e in events if e.get("kind") == "mapping.key_scan"
             and "true_heading_deg" in e}
    est, true = [], []
    for k, pose in enumerate(saved["key_poses"]):
        if k in truth:
            est.append((float(pose[0]), float(pose[1]), float(pose[2])))
            true.append(truth[k])
    return est, true


def map_figures(events: Events, true_map_yaml: str | None) -> dict[str, Any]:
    """The saved map's figures: key scans, loops, relation error and, given the world's
    map (or from a ``mapping.judged`` event the hand-over wrote), its quality."""
    saved = _saved(events)
    if saved is None:
        return {}
    judged = [e for e in events if e.get("kind") == "mapping.judged"
              and e.get("yaml") == saved["yaml"]]
    out: dict[str, Any] = {"map_key_scans": saved["key_scans"],
                           "map_loops_closed": saved["loops_closed"]}
    est, true = key_pose_pairs(events)
    if len(est) >= 2:
        e = relation_error(est, true, pairs="all")
        out["relation_error_cm"] = round(e.translation_m * 100, 2)
        out["relation_error_deg"] = round(math.degrees(e.rotation_rad), 3)
    if judged:
        for key in ("map_occupied_near_wall_pct", "map_free_truly_free_pct"):
            if key in judged[-1]:
                out[key] = judged[-1][key]
    elif true_map_yaml:
        try:
            q = map_quality(read_map_yaml(saved["yaml"]), read_map_yaml(true_map_yaml))
        except (MapFileError, OSError):
            return out
        out["map_occupied_near_wall_pct"] = round(q.occupied_near_wall_pct, 2)
        out["map_free_truly_free_pct"] = round(q.free_truly_free_pct, 2)
    return out


@dataclass(frozen=True, slots=True)
class MapCheck:
    keys: tuple[str, ...] = KEYS

    def failures(self, run: CheckRun) -> list[str]:
        wanted = {k: run.extra[k] for k in KEYS if k in run.extra}
        if not wanted:
            return []
        true_map = run.bodies[0].world.map_source if run.bodies else ""
        figures = map_figures(run.events, true_map or None)
        if not figures:
            return ["the survey saved no map (no mapping.saved event)"]
        out = []
        for key, figure in (("map_occupied_near_wall_pct", "map_occupied_near_wall_pct"),
                            ("map_free_truly_free_pct", "map_free_truly_free_pct"),
                            ("min_map_key_scans", "map_key_scans")):
            if key in wanted:
                got = figures.get(figure)
                if got is None or float(got) < float(wanted[key]):
                    out.append(f"{figure} {got} is below {wanted[key]}")
        for key, figure, scale in (("max_relation_error_m", "relation_error_cm", 0.01),
                                   ("max_relation_error_deg", "relation_error_deg", 1.0)):
            if key in wanted:
                got = figures.get(figure)
                if got is None or float(got) * scale > float(wanted[key]):
                    out.append(f"{figure} {got} is above {float(wanted[key]) / scale:g}")
        return out

    def figures(self, events: Events) -> dict[str, Any]:
        return map_figures(events, None)
