"""The dock IR code table (OI defaults, combinations, duplicates) and the window OR."""

from __future__ import annotations

import pytest

from drivers.dock_ir.oi_codes import CodeTable, CodeTableError, table_problem
from drivers.dock_ir.window import CodeWindow


class TestCodeTable:
    def test_the_defaults_are_the_oi_home_base_table(self) -> None:
        """The OI's Roomba 500 home base codes and their combinations are named by default."""
        table = CodeTable.build()
        assert table.beams(161) == {"force_field"}
        assert table.beams(164) == {"green_buoy"}
        assert table.beams(165) == {"green_buoy", "force_field"}
        assert table.beams(168) == {"red_buoy"}
        assert table.beams(169) == {"red_buoy", "force_field"}
        assert table.beams(172) == {"red_buoy", "green_buoy"}
        assert table.beams(173) == {"red_buoy", "green_buoy", "force_field"}
        assert table.beams(162) == {"virtual_wall"}
        assert not table.known(163)

    def test_other_iRobot_codes_are_named_but_not_beams(self) -> None:  # noqa: N802
        """A remote's or a Roomba 600 charger's code is described, never taken for a beam."""
        table = CodeTable.build()
        assert table.describe(136) == "remote: clean"
        assert table.describe(248).startswith("charger (600)")
        assert table.beams(136) == frozenset()
        assert table.describe(7) == "unknown"

    def test_a_code_given_twice_is_refused(self) -> None:
        """Two beams with one code: an error naming both."""
        with pytest.raises(CodeTableError, match=r"red_buoy: code 164 is given twice .*green_buoy"):
            CodeTable.build({"green_buoy": 164, "red_buoy": 164}, ())

    def test_a_combination_landing_on_a_beam_code_is_refused(self) -> None:
        """161 | 164 = 165: a beam configured as 165 would be ambiguous."""
        problem = table_problem({"force_field": 161, "green_buoy": 164, "other": 165},
                                ["force_field", "green_buoy"])
        assert problem is not None and "combine into code 165" in problem

    def test_bad_values_are_named(self) -> None:
        """A code out of 0-255, a bad name or a combined beam without a code are problems."""
        assert "expected a code 0-255" in str(table_problem({"a": 300}, ()))
        assert "plain word" in str(table_problem({"a b": 3}, ()))
        assert "has no code" in str(table_problem({"a": 3}, ["b"]))

    def test_custom_beams_for_the_seed_dock(self) -> None:
        """Any names can be given codes (the seed's far/front/centre beams)."""
        table = CodeTable.build({"far_left": 33, "far_right": 65, "center": 129}, ())
        assert table.beams(65) == {"far_right"}
        assert not table.known(33 | 65)  # no combinations unless asked


class TestCodeWindow:
    def test_codes_are_ored_over_the_window(self) -> None:
        """Codes seen at different times within the window are all seen together."""
        window = CodeWindow(("omni", "rear"), window_s=0.2)
        window.add("omni", 164, 1_000_000)
        window.add("omni", 168, 1_150_000)
        assert window.seen(1_190_000) == {"omni": {164, 168}, "rear": frozenset()}

    def test_a_code_older_than_the_window_is_forgotten(self) -> None:
        """A code is seen for window_s after it was decoded, then no more."""
        window = CodeWindow(("omni",), window_s=0.2)
        window.add("omni", 164, 1_000_000)
        window.add("omni", 168, 1_150_000)
        assert window.seen(1_250_000) == {"omni": {168}}
        assert window.seen(1_400_000) == {"omni": frozenset()}

    def test_a_later_decoding_keeps_a_code_longer(self) -> None:
        """The same code again restarts its time; an older one does not move it back."""
        window = CodeWindow(("omni",), window_s=0.1)
        window.add("omni", 161, 0)
        window.add("omni", 161, 90_000)
        window.add("omni", 161, 10_000)
        assert window.seen(180_000) == {"omni": {161}}

    def test_edges_of_an_unknown_receiver_are_ignored(self) -> None:
        """A receiver not configured does not appear."""
        window = CodeWindow(("omni",))
        window.add("rear", 161, 0)
        assert window.seen(0) == {"omni": frozenset()}

    def test_the_window_can_be_tuned(self) -> None:
        """set_window changes how long codes stay; a window below 10 ms is refused."""
        window = CodeWindow(("omni",), window_s=0.2)
        window.set_window(0.5)
        assert window.window_us == 500_000
        with pytest.raises(ValueError, match="ir_window_s"):
            window.set_window(0.0)
