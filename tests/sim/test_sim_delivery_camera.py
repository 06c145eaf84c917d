"""``robotd sim delivery-camera``: the seed's camera failure is a warning, never a hang."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from robotd.cli import main


@pytest.mark.slow
def test_delivery_camera_unplugged_warns_tells_the_customer_and_waits_on(
        tmp_path: Path) -> None:
    """QR camera unplugged: the customer is still approached; verifying finds no camera within
    a poll (no 30 s hang), emits a camera_failure warning, plays the failure sound, and the
    robot is back waiting at home; no error_recovery, no estop, nothing delivered."""
    code = main(["sim", "delivery-camera", "--quiet", "--report", str(tmp_path)])
    events = [json.loads(line) for line in
              (tmp_path / "events.jsonl").read_text().splitlines()]
    assert events[-1]["reasons"] == [] and code == 0
    failure = next(e for e in events if e["kind"] == "delivery.camera_failure")
    assert failure["category"] == "camera_failure" and "unplugged" in failure["detail"]
    asked = next(e["t"] for e in events if e.get("dst") == "mission.verifying")
    assert failure["t"] - asked <= 2.0
    sounds = [e["sound"] for e in events if e["kind"] == "delivery.sound"]
    assert sounds[:2] == ["request_qr", "failureScan"]
    assert not any(e.get("dst") in ("mission.error_recovery", "estop") for e in events)
    assert [e for e in events if e.get("kind") == "transition"][-1]["dst"] == "mission.waiting"
