"""The laundry site's own conditions, from what the staff saw (``site.*`` events).

``[success]`` keys:

- ``no_loaded_departure = true``: no robot left the base room with something in its bin unless
  it was taking clean laundry out (``site.left_base``: the last customer's laundry never rides
  along to the next one).
- ``one_robot_on_the_line = true``: never more than one robot out of the base room at once
  (``site.line_shared``): the site's one painted line, which robots cannot pass each other on.
"""

from __future__ import annotations

from typing import Any

from sim.slice import CheckRun, Events

LAUNDRY_SUCCESS_KEYS = ("no_loaded_departure", "one_robot_on_the_line")


class LaundrySiteCheck:
    keys = LAUNDRY_SUCCESS_KEYS

    def failures(self, run: CheckRun) -> list[str]:
        reasons = []
        if run.extra.get("no_loaded_departure"):
            for e in run.events:
                if e.get("kind") == "site.left_base" and float(e.get("payload_kg", 0)) > 0 \
                        and not e.get("delivering"):
                    reasons.append(f"{e.get('robot')} left base at t={float(e['t']):.1f} s "
                                   f"with {e['payload_kg']} kg aboard")
        if run.extra.get("one_robot_on_the_line"):
            for e in run.events:
                if e.get("kind") == "site.line_shared":
                    reasons.append(f"{', '.join(e['robots'])} were on the line at once at "
                                   f"t={float(e['t']):.1f} s")
        return reasons

    def figures(self, events: Events) -> dict[str, Any]:
        departures = [e for e in events if e.get("kind") == "site.left_base"]
        return {"departures": len(departures)} if departures else {}
