"""Issue 28: the cabinet seed's cases no scenario reached: fitting case 4 (the room's middle)
in ``cabinet-middle``, and a link broken for the seed's own reason, the drive controller
unable to reach its node (stalled, nothing in the scan), in ``cabinet-stall``."""

from __future__ import annotations

import itertools
import json
from pathlib import Path
from typing import Any

import pytest

from robotd.cli import main

Events = list[dict[str, Any]]


def _run(name: str, out: Path) -> tuple[int, Events]:
    code = main(["sim", name, "--quiet", "--report", str(out)])
    return code, [json.loads(line) for line in (out / "events.jsonl").read_text().splitlines()]


@pytest.fixture(scope="module")
def middle(tmp_path_factory: pytest.TempPathFactory) -> tuple[int, Events]:
    return _run("cabinet-middle", tmp_path_factory.mktemp("middle"))


@pytest.fixture(scope="module")
def stall(tmp_path_factory: pytest.TempPathFactory) -> tuple[int, Events]:
    return _run("cabinet-stall", tmp_path_factory.mktemp("stall"))


def _moves(events: Events) -> list[tuple[str, str, str]]:
    return [(e["src"], e["trigger"], e["dst"]) for e in events if e["kind"] == "transition"]


class TestCabinetMiddle:
    def test_it_passes(self, middle: tuple[int, Events]) -> None:
        assert middle[0] == 0

    def test_a_whole_turn_refused_sends_it_to_the_room_s_middle(
            self, middle: tuple[int, Events]) -> None:
        _, events = middle
        moves = _moves(events)
        assert ("mission.fitting.fit", "full_turn", "mission.fitting.go_room_middle") in moves
        assert ("mission.fitting.go_room_middle", "room_middle_set",
                "mission.fitting.drive") in moves
        go = next(e for e in events if e["kind"] == "fit.go_room_middle")
        refused = [e for e in events if e["kind"] == "fit.tried" and e["t"] < go["t"]]
        assert refused and not any(e["accepted"] for e in refused)
        found = next(e for e in events if e["kind"] == "fit.found")
        assert found["t"] > go["t"]
        # It moved out of the crates (the start was x 1.0) towards the middle (x 2.5).
        assert found["x_m"] > 1.5
        assert moves[-1][2] == "idle"


class TestCabinetStall:
    def test_it_passes(self, stall: tuple[int, Events]) -> None:
        assert stall[0] == 0

    def test_the_link_is_broken_because_the_node_could_not_be_reached(
            self, stall: tuple[int, Events]) -> None:
        """The drive controller's stall, not the LiDAR's corridor check, breaks a link
        between two nodes; the new path leaves that link out."""
        _, events = stall
        blocked = [e for e in events if e["kind"] == "link.blocked"]
        assert [b["reason"] for b in blocked] == ["stalled: no progress for 8 s"]
        closed = next(e for e in events if e["kind"] == "link.closed")
        assert closed["a"] is not None and closed["b"] is not None
        link = {closed["a"], closed["b"]}
        after = [e for e in events if e["kind"] == "path.planned" and e["t"] >= closed["t"]]
        nodes = after[0]["nodes"]
        assert not any({a, b} == link for a, b in itertools.pairwise(nodes))
        assert [e["cabinet"] for e in events if e["kind"] == "cabinet.arrived"] == ["c2"]
