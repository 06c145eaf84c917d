"""The cabinet robot's layers of ``trajectory.png``: the node graph (links grey, broken links
red), the fits (refused: grey crosses; accepted: an arrow at the pose found) and each arrival
at a cabinet (a star at the true position, labelled with the cabinet and the error)."""

from __future__ import annotations

import math
from typing import Any

from sim.robots.cabinet.checks import arrival_error_m
from sim.world.floor_plan import World

_ARROW_M = 0.35


def draw_cabinet(ax: Any, _world: World, events: list[dict[str, Any]]) -> None:
    """The graph, the fits and the arrivals onto ``ax`` (nothing without ``graph.built``)."""
    graph = next((e for e in events if e.get("kind") == "graph.built"), None)
    if graph is None:
        return
    xy = {str(n[0]): (float(n[1]), float(n[2])) for n in graph.get("nodes", [])}
    for i, (a, b) in enumerate(graph.get("links", [])):
        if a in xy and b in xy:
            ax.plot([xy[a][0], xy[b][0]], [xy[a][1], xy[b][1]], color="#9aa5b1", lw=0.6,
                    alpha=0.7, zorder=2.2, label="node graph links" if i == 0 else None)
    ax.scatter([p[0] for p in xy.values()], [p[1] for p in xy.values()], s=14,
               color="#34495e", zorder=2.4, label="nodes")
    resets = [float(e["t"]) for e in events if e.get("kind") == "links.reset"]
    labelled: set[bool] = set()
    for e in (e for e in events if e.get("kind") == "link.closed" and e.get("a_xy")):
        (ax_, ay), (bx, by) = e["a_xy"], e["b_xy"]
        reset = any(t > float(e["t"]) for t in resets)
        ax.plot([ax_, bx], [ay, by], color="red", lw=2.4, zorder=4.6, ls="--" if reset else "-",
                label=None if reset in labelled else
                ("broken links, reset later" if reset else "broken links"))
        labelled.add(reset)
    refused = [e for e in events if e.get("kind") == "fit.tried" and not e.get("accepted")]
    if refused:
        ax.scatter([e["x_m"] for e in refused], [e["y_m"] for e in refused], marker="x",
                   s=40, color="#7f8c8d", zorder=4.7, label=f"fits refused ({len(refused)})")
    for i, e in enumerate(e for e in events if e.get("kind") == "fit.found"):
        x, y, h = float(e["est_x_m"]), float(e["est_y_m"]), math.radians(e["est_heading_deg"])
        ax.annotate("", xy=(x + _ARROW_M * math.cos(h), y + _ARROW_M * math.sin(h)),
                    xytext=(x, y), zorder=4.8,
                    arrowprops={"arrowstyle": "->", "color": "#16a085", "lw": 1.8})
        ax.plot([x], [y], "o", color="#16a085", ms=5, zorder=4.8,
                label="fits (pose found)" if i == 0 else None)
    arrivals = [e for e in events if e.get("kind") == "cabinet.arrived"]
    for i, e in enumerate(arrivals):
        ax.plot([e["x_m"]], [e["y_m"]], marker="*", color="gold", markeredgecolor="black",
                ms=13, zorder=5.0, label="cabinet arrivals" if i == 0 else None)
        ax.annotate(f"{e.get('cabinet')} ({arrival_error_m(e) * 100:.1f} cm)",
                    (e["x_m"], e["y_m"]), textcoords="offset points", xytext=(6, 6),
                    fontsize=7, zorder=5.0)
    failed = [e for e in events if e.get("kind") == "mission.failed" and "x_m" in e]
    for e in failed:
        ax.plot([e["x_m"]], [e["y_m"]], marker="X", color="crimson", ms=12, zorder=5.0,
                label=f"mission.failed ({e.get('cabinet')})")
