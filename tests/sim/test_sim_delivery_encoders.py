"""``robotd sim delivery-encoders``: the seed's encoder failure mid-route is survived."""

from __future__ import annotations

import itertools
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from robotd.cli import main
from sim.devices.motor_board.encoder_fault import FreezableEncoders
from sim.world.plant import RecordingPlant


def test_frozen_encoders_report_the_same_ticks_and_resume_without_a_jump() -> None:
    """While frozen the board's counts stay; after restore they run on from there."""
    plant = RecordingPlant(ticks=(100, 200))
    board = FreezableEncoders(plant)
    board.freeze()
    plant.ticks = (500, 650)
    assert board.encoder_ticks() == (100, 200)
    board.restore()
    assert board.encoder_ticks() == (100, 200)
    plant.ticks = (510, 662)
    assert board.encoder_ticks() == (110, 212)


def _speeds(poses: list[dict[str, Any]]) -> list[float]:
    return [math.hypot(b["x_m"] - a["x_m"], b["y_m"] - a["y_m"]) / (b["t"] - a["t"])
            for a, b in itertools.pairwise(poses)]


@pytest.mark.slow
def test_delivery_encoders_detects_slows_stays_localised_and_delivers(tmp_path: Path) -> None:
    """Frozen encoders on the way: detected (category encoder), half speed and localised
    within 10 cm (p95) while frozen, full speed again after; order 7 delivered, home."""
    code = main(["sim", "delivery-encoders", "--quiet", "--report", str(tmp_path)])
    events = [json.loads(line) for line in
              (tmp_path / "events.jsonl").read_text().splitlines()]
    assert events[-1]["reasons"] == [] and code == 0
    failed = next(e for e in events if e["kind"] == "odometry.encoders_failed")
    back = next(e for e in events if e["kind"] == "odometry.encoders_back")
    assert failed["category"] == "encoder" and failed["commanded_pwm"] >= 40
    assert failed["state"] == "mission.navigating_to_warehouse"
    assert not any(e.get("dst") == "mission.error_recovery" for e in events)
    poses = [e for e in events if e["kind"] == "nav.pose"]
    during = [e for e in poses if failed["t"] <= e["t"] <= back["t"]]
    after = [e for e in poses if back["t"] < e["t"] <= back["t"] + 30]
    errors = [math.hypot(e["est_x_m"] - e["x_m"], e["est_y_m"] - e["y_m"]) for e in during]
    assert float(np.percentile(errors, 95)) < 0.10
    cruise = 0.2  # drive.cruise_mps
    assert max(_speeds(during)) <= cruise / 2 * 1.1
    assert max(_speeds(after)) > cruise * 0.9
    assert [e["order_id"] for e in events if e["kind"] == "delivery.delivered"] == [7]
