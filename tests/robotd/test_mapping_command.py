"""``robotd map``'s exits: a map from a small log, no scan, a file that is not there."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from behaviours.nav.mapping.scan import Scan
from hal.occupancy_map import OCCUPIED, read_map_yaml
from robotd.cli import main
from robotd.mapping.clf import write_clf


def _room_scan(t_s: float, x: float, y: float) -> Scan:
    """360 beams from (x, y) in a 4 x 3 m room (walls at x 0 and 4, y 0 and 3)."""
    angles = -math.pi + 2 * math.pi * np.arange(360) / 360
    c, s = np.cos(angles), np.sin(angles)
    with np.errstate(divide="ignore"):
        tx = np.where(c > 0, (4 - x) / c, np.where(c < 0, -x / c, np.inf))
        ty = np.where(s > 0, (3 - y) / s, np.where(s < 0, -y / s, np.inf))
    return Scan(t_s, np.round(np.minimum(tx, ty), 3), -math.pi, 2 * math.pi / 360, 12.0,
                (x, y, 0.0))


class TestMapCommand:
    def test_a_small_log_gives_a_map_and_a_trajectory(self, tmp_path: Path,
                                                      capsys: pytest.CaptureFixture[str]
                                                      ) -> None:
        """A robot crossing a room: exit 0, the walls in the map, a pose per scan."""
        scans = [_room_scan(0.5 * k, 1.0 + 0.1 * k, 1.5) for k in range(16)]
        log = tmp_path / "room.clf"
        with log.open("w") as out:
            write_clf(out, scans)
        code = main(["map", "--from-log", str(log), "--out", str(tmp_path / "room"),
                     "--trajectory", str(tmp_path / "room.txt")])
        assert code == 0
        assert "unreadable lines skipped: 0" in capsys.readouterr().out
        grid = read_map_yaml(tmp_path / "room.yaml")
        assert int((grid.cells == OCCUPIED).sum()) > 100
        lines = (tmp_path / "room.txt").read_text().splitlines()
        assert len(lines) == 16
        t, x, y, _theta = (float(v) for v in lines[-1].split())
        assert (t, x, y) == pytest.approx((7.5, 2.5, 1.5), abs=0.02)

    def test_a_log_with_no_scan_exits_1_and_counts_its_bad_lines(
            self, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
        """Only junk: exit 1, the reason, and the junk counted."""
        log = tmp_path / "junk.clf"
        log.write_text("hello\nFLASER 3 1\n")
        assert main(["map", "--from-log", str(log), "--out", str(tmp_path / "m")]) == 1
        captured = capsys.readouterr()
        assert "no FLASER or ROBOTLASER1 scan" in captured.err
        assert "unreadable lines skipped: 2" in captured.out
        assert not (tmp_path / "m.yaml").exists()

    def test_a_log_that_is_not_there_exits_2(self, tmp_path: Path,
                                             capsys: pytest.CaptureFixture[str]) -> None:
        """The path and the reason, exit 2."""
        assert main(["map", "--from-log", str(tmp_path / "none.clf"),
                     "--out", str(tmp_path / "m")]) == 2
        assert "none.clf" in capsys.readouterr().err
