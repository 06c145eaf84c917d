"""Real sites in the simulator (issue 30): Nav2's depot with its zones, and its warehouse with
RelayBot, kidnapped or not."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

from robotd.cli import main


def _run(name: str, tmp_path: Path, seed: int = 1) -> tuple[int, list[dict[str, Any]]]:
    code = main(["sim", name, "--quiet", "--seed", str(seed), "--report", str(tmp_path)])
    events = [json.loads(line) for line in
              (tmp_path / "events.jsonl").read_text().splitlines()]
    return code, events


def test_nav_depot_keeps_out_of_the_zones_and_under_their_limits(tmp_path: Path) -> None:
    """The patrol route across the depot: every goal within 10 cm, p95 <= 5 cm, no true pose
    in a keep-out cell, never faster than a speed zone allows; the plans went round the
    zones and both limited zones were entered."""
    code, events = _run("nav-depot", tmp_path)
    result = events[-1]
    assert result["reasons"] == [] and code == 0
    figures = result["figures"]["sim-1"]
    assert figures["goals_reached"] == 5 and figures["collisions"] == 0
    assert figures["zone_speed_max_pct_of_limit"] <= 100.0
    limits = {e["limit"] for e in events if e["kind"] == "nav.speed_limit"}
    assert {50.0, 75.0} <= limits
    zones = next(e for e in events if e["kind"] == "nav.zones")
    assert zones["keepout_file"].endswith("depot_keepout.yaml")


def test_delivery_warehouse_delivers_across_the_site(tmp_path: Path) -> None:
    """RelayBot on the 1.7 M-cell warehouse: the order delivered, home within 10 cm,
    localisation p95 <= 5 cm; the shelf is some 27 m of aisles from home."""
    code, events = _run("delivery-warehouse", tmp_path)
    result = events[-1]
    assert result["reasons"] == [] and code == 0
    shelf = next(e for e in events if e["kind"] == "delivery.at_warehouse")
    assert math.hypot(shelf["x_m"] - 11.0, shelf["y_m"] - 18.0) <= 0.10


def test_kidnapped_on_the_warehouse_it_relocalises_and_delivers(tmp_path: Path) -> None:
    """Carried 13 m on the way to the shelf: lost seen within 10 s, relocalised over the
    whole map within 30 s of the kidnap (the estimate within 10 cm of the truth), and the
    order still delivered."""
    code, events = _run("delivery-warehouse-kidnap", tmp_path)
    result = events[-1]
    assert result["reasons"] == [] and code == 0
    t0 = next(e["t"] for e in events if e.get("action") == "body.teleport")
    found = next(e for e in events if e["kind"] == "nav.relocalised")
    assert found["t"] - t0 <= 30.0
    assert math.hypot(found["est_x_m"] - found["x_m"], found["est_y_m"] - found["y_m"]) < 0.10
    assert [e["order_id"] for e in events if e["kind"] == "delivery.delivered"] == [7]
