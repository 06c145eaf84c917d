"""``map-depot`` (issue 30), quick: the survey explores the depot from scratch for 4 minutes
of its time (the built-in explores until no frontier is left: 28 minutes simulated, about
6 minutes of wall time here), comes back to where it started, saves the map, and hands over
to the patrol, which localises and drives two goals on the map it made. The same success
conditions as the built-in: of the cells it saw, >= 95 % of occupied cells within one cell of
a true wall and >= 98 % of free cells truly free; relation error over all key-scan pairs
<= 5 cm and <= 1 deg; the goals within 10 cm."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

from robotd.cli import main
from sim.scenario import builtins

QUICK = {
    "explore_time_limit_s = 1500.0": "explore_time_limit_s = 240.0",
    "goals = [[16.6, 4.3], [19.15, 10.5], [28.2, 8.8], [2.0, 7.5]]":
        "goals = [[9.0, 8.5], [2.0, 7.5]]",
    'name = "map-depot"': 'name = "map-depot-quick"',
}


def _quick(tmp_path: Path) -> Path:
    source = Path(str(builtins()["map-depot"])) / "map-depot.toml"
    text = source.read_text(encoding="utf-8")
    text = text.replace('"../../../maps/depot.yaml"',
                        json.dumps(str((source.parent / "../../../maps/depot.yaml").resolve())))
    for old, new in QUICK.items():
        assert old in text
        text = text.replace(old, new)
    out = tmp_path / "map-depot-quick.toml"
    out.write_text(text, encoding="utf-8")
    return out


def test_the_depot_mapped_from_scratch_then_patrolled_on_its_own_map(tmp_path: Path) -> None:
    scenario = _quick(tmp_path)
    code = main(["sim", str(scenario), "--quiet", "--report", str(tmp_path / "report")])
    events: list[dict[str, Any]] = [
        json.loads(line) for line in (tmp_path / "report" / "events.jsonl").read_text()
        .splitlines()]
    result = events[-1]
    assert result["reasons"] == [] and code == 0
    figures = result["figures"]["sim-1"]
    assert figures["map_key_scans"] >= 40
    assert figures["relation_error_cm"] <= 5.0 and figures["relation_error_deg"] <= 1.0
    assert figures["map_occupied_near_wall_pct"] >= 95.0
    assert figures["map_free_truly_free_pct"] >= 98.0
    judged = next(e for e in events if e["kind"] == "mapping.judged")
    assert judged["yaml"].endswith("maps/depot-made.yaml")
    start = next(e for e in events if e["kind"] == "nav.start")
    assert start["initial_pose"] == "config"  # from where the survey left it
    reached = [e for e in events if e["kind"] == "nav.goal_reached"]
    assert len(reached) == 2
    for e in reached:
        assert math.hypot(e["goal_x_m"] - e["x_m"], e["goal_y_m"] - e["y_m"]) <= 0.10
    assert any(e["kind"] == "mapping.returned" for e in events)
