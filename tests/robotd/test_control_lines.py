"""A client's bytes into lines, and the work budget that keeps one client from holding the loop."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from robotd.control.lines import (
    BLANK_LINES_PER_UNIT,
    TOO_LONG,
    LineSplitter,
    TooLong,
    WorkBudget,
    blank_units,
)


def split_all(splitter: LineSplitter, chunks: list[bytes]) -> tuple[list[bytes | TooLong], int]:
    lines: list[bytes | TooLong] = []
    blank = 0
    for chunk in chunks:
        more, more_blank = splitter.feed(chunk)
        lines += more
        blank += more_blank
    return lines, blank


class TestLineSplitter:
    def test_lines_split_across_chunks_come_out_whole(self) -> None:
        """A line that arrives in pieces is one line; an unfinished one waits for its end."""
        lines, blank = split_all(LineSplitter(100), [b'{"a"', b':1}\n{"b"', b':2}\n{"c"'])
        assert (lines, blank) == ([b'{"a":1}', b'{"b":2}'], 0)

    def test_blank_and_whitespace_lines_are_counted_not_returned(self) -> None:
        lines, blank = split_all(LineSplitter(100), [b"\n \n\t\nx\n\r\n", b"\n"])
        assert (lines, blank) == ([b"x"], 5)

    def test_a_megabyte_of_newlines_is_counted_in_one_go(self) -> None:
        lines, blank = LineSplitter(100).feed(b"\n" * 1_000_000)
        assert (lines, blank) == ([], 1_000_000)

    def test_a_line_over_the_limit_is_refused_once_before_its_end_arrives(self) -> None:
        """Refused as soon as it is too long; its bytes dropped up to its newline; the line
        after it is read as usual."""
        splitter = LineSplitter(10)
        first, _ = splitter.feed(b"x" * 11)
        rest, _ = split_all(splitter, [b"x" * 1000, b"x\nok\n"])
        assert (first, rest) == ([TOO_LONG], [b"ok"])

    def test_a_complete_line_over_the_limit_is_refused(self) -> None:
        lines, _ = LineSplitter(10).feed(b"y" * 11 + b"\nok\n")
        assert lines == [TOO_LONG, b"ok"]

    @given(st.lists(st.sampled_from([b"\n", b" ", b"a", b'{"x":1}', b"\n\n"]), max_size=60),
           st.data())
    def test_any_chunking_gives_the_lines_of_one_split(self, pieces: list[bytes],
                                                       data: st.DataObject) -> None:
        """However the stream is cut into chunks, the lines and the blank count are those of
        splitting it whole."""
        stream = b"".join(pieces)
        cuts = sorted(data.draw(st.lists(st.integers(0, len(stream)), max_size=8)))
        chunks = [stream[a:b] for a, b in zip([0, *cuts], [*cuts, len(stream)], strict=True)]
        lines, blank = split_all(LineSplitter(1000), chunks)
        whole = stream.split(b"\n")[:-1]
        assert lines == [x for x in whole if x.strip()]
        assert blank == sum(1 for x in whole if not x.strip())


class TestWorkBudget:
    def test_a_burst_is_free_then_the_rate_holds(self) -> None:
        """Within the burst no wait; past it, the wait that brings it back to the rate."""
        budget = WorkBudget(rate_per_s=100, burst=50, now_s=0.0)
        assert budget.spend(50, 0.0) == 0.0
        assert budget.spend(10, 0.0) == pytest.approx(0.1)
        assert budget.spend(10, 1.0) == 0.0  # 1 s refilled 100 (capped at the burst of 50)

    def test_blank_lines_cost_a_unit_per_256(self) -> None:
        assert blank_units(BLANK_LINES_PER_UNIT * 4) == 4
