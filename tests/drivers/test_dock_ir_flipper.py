"""Flipper Zero .ir files: raw blocks read, parsed blocks skipped, bad files named by line."""

from __future__ import annotations

from pathlib import Path

import pytest

from drivers.dock_ir.flipper import FlipperFormatError, parse_ir_text, read_ir_file, signal_edges

DATA = Path(__file__).parent / "data" / "roomba_dock.ir"
HEADER = "Filetype: IR signals file\nVersion: 1\n"
RAW = "name: A\ntype: raw\nfrequency: 38000\nduty_cycle: 0.330000\ndata: 3000 1000 1000\n"


class TestReading:
    def test_the_test_capture_has_its_raw_signals_and_a_note(self) -> None:
        """Our capture holds six raw signals; its parsed block is skipped with a note."""
        capture = read_ir_file(DATA)
        assert [s.name for s in capture.signals] == [
            "Force_field", "Green_buoy", "Red_buoy", "Red_green_overlap", "Virtual_wall",
            "Cut_short"]
        assert capture.signals[0].frequency_hz == 38000
        assert capture.signals[0].line == 8
        assert len(capture.notes) == 1 and "type: parsed" in capture.notes[0]

    def test_durations_alternate_mark_and_space(self) -> None:
        """Edges start with a mark at t0 and alternate; active-low marks are low."""
        edges = signal_edges((3000, 1000, 1000), t0_us=10)
        assert [(e.level, e.t_us) for e in edges] == [
            (False, 10), (True, 3010), (False, 4010), (True, 5010)]

    def test_comments_and_blank_lines_are_ignored(self) -> None:
        """# lines and blank lines anywhere do not matter."""
        capture = parse_ir_text(f"{HEADER}#\n\n# c\n{RAW}#\n")
        assert capture.signals[0].durations_us == (3000, 1000, 1000)


class TestMalformed:
    @pytest.mark.parametrize(("text", "line", "words"), [
        ("", 1, "empty file"),
        ("Filetype: Flipper SubGhz\nVersion: 1\n", 1, "IR signals file"),
        ("Filetype: IR signals file\nVersion: 2\n", 2, "unsupported version"),
        (HEADER + "type: raw\n", 3, "expected 'name:'"),
        (HEADER + "name: A\ntype: raw\nfrequency: 38000\nduty_cycle: 0.33\ndata: 3000 x\n", 7,
         "data must be durations"),
        (HEADER + "name: A\ntype: raw\nfrequency: 38k\nduty_cycle: 0.33\ndata: 3000\n", 5,
         "frequency"),
        (HEADER + "name: A\ntype: raw\nfrequency: 38000\nduty_cycle: 0.33\n", 3, "no 'data:'"),
        (HEADER + "name: A\ntype: weird\n", 4, "type must be raw or parsed"),
        (HEADER + "name: A\nthis line has no colon\n", 4, "expected 'key: value'"),
    ])
    def test_errors_name_the_line(self, text: str, line: int, words: str) -> None:
        """Each malformed file gives FILE:LINE: message with the line at fault."""
        with pytest.raises(FlipperFormatError) as err:
            parse_ir_text(text, "f.ir")
        assert err.value.line == line
        assert str(err.value).startswith(f"f.ir:{line}: ")
        assert words in err.value.message
