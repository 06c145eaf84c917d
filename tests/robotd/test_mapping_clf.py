"""CARMEN logs: FLASER and ROBOTLASER1 read, no returns, unreadable lines counted, round trip."""

from __future__ import annotations

import io
import math

import numpy as np
import pytest

from behaviours.nav.mapping.scan import Scan
from robotd.mapping.clf import parse_clf, write_clf

FLASER = ("FLASER 4 1.0 2.5 81.91 3.0 1.1 2.0 0.5 1.0 2.0 0.5 1000.25 intel 1000.26")


class TestReadClf:
    def test_reads_a_flaser_line(self) -> None:
        """Ranges, the 180 degree fan, the odometry pose and the laser's offset."""
        log = parse_clf([FLASER])
        (scan,) = log.scans
        assert scan.timestamp_s == 1000.25
        assert scan.odom == (1.0, 2.0, 0.5)
        assert scan.laser_offset == pytest.approx((0.1 * math.cos(0.5), -0.1 * math.sin(0.5),
                                                   0.0))
        assert scan.angle_min_rad == -math.pi / 2
        assert scan.angle_increment_rad == pytest.approx(math.pi / 4)

    def test_a_range_at_the_maximum_is_no_return(self) -> None:
        """81.91 m (the SICK's no return) gives no point; the other three do."""
        (scan,) = parse_clf([FLASER]).scans
        assert scan.returns().tolist() == [True, True, False, True]
        assert scan.points().shape == (3, 2)

    def test_unreadable_lines_are_skipped_and_counted(self) -> None:
        """Short, garbled and binary lines are each counted with their line number; other
        messages and comments are not errors."""
        lines = ["# a comment", FLASER, "FLASER 4 1.0 2.0", "\x00\x7fjunk",
                 "ODOM 1 2 3 0 0 0 5 host 5", "FLASER 2 1.0 x 0 0 0 0 0 0 1 h 1",
                 FLASER + " extra", ""]
        log = parse_clf(lines)
        assert len(log.scans) == 1
        assert [n for n, _ in log.skipped] == [3, 4, 6, 7]
        assert "fewer given" in log.skipped[0][1]
        assert log.ignored == 1


class TestWriteClf:
    def test_what_is_written_reads_back(self) -> None:
        """ROBOTLASER1 and TRUEPOS lines round-trip; no return is written as the maximum."""
        ranges = np.array([1.0, np.inf, 3.25, 0.5])
        scan = Scan(12.5, ranges, -math.pi, math.pi / 2, 12.0, (1.0, -2.0, 0.25),
                    (0.1, 0.0, 0.0))
        out = io.StringIO()
        assert write_clf(out, [scan], {12.5: (1.01, -2.02, 0.26)}) == 2
        log = parse_clf(out.getvalue().splitlines())
        assert log.skipped == []
        (back,) = log.scans
        assert back.ranges_m.tolist() == [1.0, 12.0, 3.25, 0.5]
        assert back.returns().tolist() == [True, False, True, True]
        assert back.odom == pytest.approx(scan.odom)
        assert back.laser_offset == pytest.approx(scan.laser_offset, abs=1e-6)
        assert back.angle_min_rad == pytest.approx(-math.pi, abs=1e-6)
        assert log.true_poses == [(12.5, (1.01, -2.02, 0.26))]
