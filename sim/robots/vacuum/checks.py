"""Success conditions of the vacuum's scenarios, read from the run's events.

``[success]`` keys (optional):

- ``vacuum_events = ["clean.virtual_wall", "dock.reverse_guard"]``: each of these event kinds
  happened at least once (branches that are events rather than states).
- ``dock_results = [905, 0]``: the ``dock.result`` error codes (0: docked), in this order.
"""

from __future__ import annotations

from typing import Any

from sim.slice import CheckRun, Events

VACUUM_SUCCESS_KEYS = ("vacuum_events", "dock_results")


class VacuumCheck:
    """The vacuum's conditions (``VACUUM_SUCCESS_KEYS``) and figures."""

    keys = VACUUM_SUCCESS_KEYS

    def failures(self, run: CheckRun) -> list[str]:
        reasons: list[str] = []
        kinds = {str(e.get("kind")) for e in run.events}
        missing = [k for k in run.extra.get("vacuum_events", []) if k not in kinds]
        if missing:
            reasons.append(f"no {', '.join(missing)} event")
        if "dock_results" in run.extra:
            got = [e.get("error_code") for e in run.events if e.get("kind") == "dock.result"]
            if got != list(run.extra["dock_results"]):
                reasons.append(f"dock_results: {got}, expected {list(run.extra['dock_results'])}")
        return reasons

    def figures(self, events: Events) -> dict[str, Any]:
        turns = sum(1 for e in events if e.get("kind") == "clean.virtual_wall")
        return {"virtual_wall_turns": turns} if turns else {}
