"""``robotd sim delivery-stuck``: the error table's navigation rows in one mission: an
obstacle under 10 cm (stop, back up 20 cm checking behind, replan), then stuck: replanned
until 30 s without progress, an alternate path, error_recovery, home."""

from __future__ import annotations

import json
from typing import Any

import pytest

from robotd.cli import main


@pytest.fixture(scope="module")
def events(tmp_path_factory: pytest.TempPathFactory) -> list[dict[str, Any]]:
    out = tmp_path_factory.mktemp("stuck")
    assert main(["sim", "delivery-stuck", "--quiet", "--report", str(out)]) == 0
    return [json.loads(line) for line in (out / "events.jsonl").read_text().splitlines()]


def _kind(events: list[dict[str, Any]], kind: str) -> list[dict[str, Any]]:
    return [e for e in events if e["kind"] == kind]


def test_an_obstacle_under_10_cm_backs_the_robot_up_20_cm(events: list[dict[str, Any]]
                                                          ) -> None:
    obstacle = _kind(events, "delivery.obstacle")[0]
    assert obstacle["distance_cm"] < 10
    assert obstacle["backed_m"] == pytest.approx(0.2, abs=0.02)
    assert obstacle["behind_m"] > 0.25  # the LiDAR checked behind: room to back up
    replanned = [e for e in events if e["kind"] == "delivery.goal" or (
        e["kind"] == "transition" and e["src"] == "mission.navigating_to_warehouse")]
    assert replanned  # the goal went on after it


def test_stuck_means_30_s_without_progress_then_an_alternate_path(
        events: list[dict[str, Any]]) -> None:
    snag = next(e for e in events if e["kind"] == "script" and e["action"] == "body.snag")
    stuck = _kind(events, "delivery.stuck")
    assert [s["action"] for s in stuck] == ["replan", "replan", "alternate_path"]
    assert stuck[-1]["stuck_s"] >= 30.0
    assert stuck[-1]["t"] - snag["t"] >= 30.0
    alternate = _kind(events, "delivery.alternate_path")[0]
    assert alternate["t"] == stuck[-1]["t"]
    assert _kind(events, "delivery.alternate_result")[0]["reason"] == "no_progress"


def test_then_error_recovery_home_and_waiting(events: list[dict[str, Any]]) -> None:
    moves = [(e["src"], e["trigger"], e["dst"]) for e in events if e["kind"] == "transition"]
    assert ("mission.navigating_to_warehouse", "navigation_error",
            "mission.error_recovery") in moves
    assert moves[-1] == ("mission.error_recovery", "recovery_complete", "mission.waiting")
    assert _kind(events, "delivery.recovery")[0]["category"] == "stuck"
