"""``robotd sim delivery``, ``delivery-reject``, ``delivery-faults``, ``delivery-recovery``."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from robotd.cli import main


def _run(name: str, tmp_path: Path) -> tuple[int, list[dict[str, Any]]]:
    code = main(["sim", name, "--quiet", "--report", str(tmp_path)])
    events = [json.loads(line) for line in
              (tmp_path / "events.jsonl").read_text().splitlines()]
    return code, events


@pytest.mark.slow
@pytest.mark.parametrize("name", ["delivery", "delivery-reject", "delivery-faults",
                                  "delivery-recovery"])
def test_each_delivery_built_in_passes(name: str, tmp_path: Path) -> None:
    """Each delivery built-in meets its success conditions (sounds, box, durations, the
    error table's endings), with no collision, and draws its trajectory."""
    code, events = _run(name, tmp_path)
    assert events[-1]["reasons"] == []
    assert code == 0
    assert (tmp_path / "trajectory.png").stat().st_size > 0


@pytest.mark.slow
def test_delivery_hands_over_for_exactly_10_s(tmp_path: Path) -> None:
    """``robotd sim delivery``: order 7 verified, fetched, handed over for 10.0 s of virtual
    time, back home within 10 cm; the sounds in the seed's order; the box opened twice."""
    code, events = _run("delivery", tmp_path)
    assert code == 0
    into = next(e["t"] for e in events if e.get("dst") == "mission.delivering")
    out = next(e["t"] for e in events if e.get("src") == "mission.delivering")
    assert out - into == pytest.approx(10.0, abs=1e-3)
    sounds = [e["sound"] for e in events if e["kind"] == "delivery.sound"]
    assert sounds == ["request_qr", "successScan", "order_accepted", "announce_order_7",
                      "delivery_greeting"]
    figures = events[-1]["figures"]["sim-1"]
    assert abs(figures["final_x_m"]) < 0.1 and abs(figures["final_y_m"]) < 0.1
