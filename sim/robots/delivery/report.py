"""The delivery robot's layers of ``trajectory.png``: home, where the customer was seen and
walked, the warehouse stop, each hand-over (labelled with the order) and each refused code."""

from __future__ import annotations

from typing import Any

from sim.world.floor_plan import World

_HOME_XY_M = (0.0, 0.0)  # the seed's home (0, 0) in the map frame
_REFUSED = ("delivery.order_rejected", "delivery.order_invalid")


def draw_delivery(ax: Any, _world: World, events: list[dict[str, Any]]) -> None:
    """Home, customers, warehouse and hand-overs onto ``ax`` (nothing for other robots)."""
    if not any(str(e.get("kind", "")).startswith("delivery.") for e in events):
        return
    home = next(((float(e["goal_x_m"]), float(e["goal_y_m"])) for e in events
                 if e.get("kind") == "delivery.goal" and e.get("why") == "home"), _HOME_XY_M)
    ax.plot(*home, marker="P", color="#2c3e50", ms=12, zorder=4.9,
            label=f"home ({home[0]:g}, {home[1]:g})")
    walks = [e for e in events if e.get("kind") == "script" and e.get("action") == "person.walk"]
    for i, e in enumerate(walks):
        points = e.get("points") or []
        if len(points) >= 2:
            ax.plot([p[0] for p in points], [p[1] for p in points], color="purple", lw=1.2,
                    ls=":", zorder=3.1, label="a person walks" if i == 0 else None)
    seen = [e for e in events if e.get("kind") == "delivery.person_detected"]
    if seen:
        ax.scatter([e["map_x_m"] for e in seen], [e["map_y_m"] for e in seen], marker="o",
                   facecolors="none", edgecolors="purple", s=80, zorder=4.7,
                   label="customer detected (LiDAR)")
    stops = [e for e in events if e.get("kind") == "delivery.at_warehouse"]
    if stops:
        ax.scatter([e["x_m"] for e in stops], [e["y_m"] for e in stops], marker="s", s=60,
                   color="#d35400", zorder=4.8, label="warehouse (loading)")
    for i, e in enumerate(e for e in events if e.get("kind") == "delivery.delivered"):
        ax.plot([e["x_m"]], [e["y_m"]], marker="*", color="gold", markeredgecolor="black",
                ms=14, zorder=5.0, label="hand-over" if i == 0 else None)
        ax.annotate(f"order {e.get('order_id')}", (e["x_m"], e["y_m"]), fontsize=7,
                    textcoords="offset points", xytext=(6, 6), zorder=5.0)
    refused = [e for e in events if e.get("kind") in _REFUSED and "x_m" in e]
    if refused:
        ax.scatter([e["x_m"] for e in refused], [e["y_m"] for e in refused], marker="x",
                   s=60, color="crimson", zorder=5.0, label=f"codes refused ({len(refused)})")
