"""``robotd map --from-log`` on a CARMEN log recorded in the simulator on Nav2's depot map.

One recorded drive (about 76 m round the depot's hall, 5 scans a second, the body's wheel
slip in the odometry) serves every test here; the log gets unreadable lines added, which the
command must skip and count.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from behaviours.nav.mapping.metrics import map_quality, relation_error
from hal.occupancy_map import read_map_yaml
from robotd.cli import main
from robotd.mapping.clf import read_clf
from sim.mapping.depot_run import MAPS_DIR, record_run, write_recording

GARBAGE = ["this line is no CARMEN message\n", "FLASER 180 1.0 2.0\n",
           "\x00\x01\x02 binary\n", "ROBOTLASER1 0 -1.57 x\n"]


@pytest.fixture(scope="module")
def mapped(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str]:
    root = tmp_path_factory.mktemp("depot")
    clf = write_recording(record_run(seed=1), root / "depot.clf")
    lines = clf.read_text().splitlines(keepends=True)
    for k, junk in enumerate(GARBAGE):
        lines.insert(100 + 250 * k, junk)
    clf.write_text("".join(lines))
    return root, str(clf)


@pytest.fixture(scope="module")
def run_output(mapped: tuple[Path, str]) -> str:
    root, clf = mapped
    capture = root / "stdout.txt"
    import contextlib

    with capture.open("w") as out, contextlib.redirect_stdout(out):
        code = main(["map", "--from-log", clf, "--out", str(root / "map" / "depot"),
                     "--trajectory", str(root / "trajectory.txt")])
    assert code == 0
    return capture.read_text()


class TestMapFromLog:
    def test_unreadable_lines_are_skipped_and_counted(self, run_output: str) -> None:
        """Exit 0, and the four bad lines are counted, with their line numbers."""
        assert "unreadable lines skipped: 4" in run_output
        assert run_output.count("depot.clf:") >= 4

    def test_the_key_scans_are_within_5_cm_and_1_deg_of_the_truth(
            self, mapped: tuple[Path, str], run_output: str) -> None:
        """The relation metric over all key-scan pairs and consecutive ones (trajectory file
        against the log's TRUEPOS lines): <= 5 cm and <= 1 deg."""
        root, clf = mapped
        log = read_clf(clf)
        truth = dict(log.true_poses)
        rows = [line.split() for line in (root / "trajectory.txt").read_text().splitlines()]
        assert len(rows) == len(log.scans)
        est = {float(r[0]): (float(r[1]), float(r[2]), float(r[3])) for r in rows}
        # The key scans: every ~0.3 m of the truth (the command's own key scans are printed).
        stamps, last = [], None
        for stamp, pose in sorted(truth.items()):
            if last is None or math.hypot(pose[0] - last[0], pose[1] - last[1]) >= 0.3:
                stamps.append(stamp)
                last = pose
        for pairs in ("consecutive", "all"):
            e = relation_error([est[s] for s in stamps], [truth[s] for s in stamps],
                               pairs=pairs)
            assert e.translation_m <= 0.05, pairs
            assert math.degrees(e.rotation_rad) <= 1.0, pairs
        assert "relation error against TRUEPOS (all key-scan pairs" in run_output

    def test_the_map_matches_the_depot(self, mapped: tuple[Path, str],
                                       run_output: str) -> None:
        """Of the cells seen: >= 95 % of occupied cells within one cell of a true wall,
        >= 98 % of free cells truly free."""
        root, _clf = mapped
        quality = map_quality(read_map_yaml(root / "map" / "depot.yaml"),
                              read_map_yaml(MAPS_DIR / "depot.yaml"))
        assert quality.occupied_near_wall_pct >= 95.0
        assert quality.free_truly_free_pct >= 98.0
        assert quality.occupied_cells > 2000
