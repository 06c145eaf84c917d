"""Live settings: validated like the file, listeners told of changes."""

from __future__ import annotations

import pytest

from robotd.config.loader import defaults
from robotd.config.settings import Checked, Settings


class TestSettings:
    def test_set_validates_like_the_file(self) -> None:
        """An out-of-range value is refused with the key and the bound; nothing changes."""
        s = Settings(defaults())
        with pytest.raises(ValueError, match=r"line_follow.kp: must be >= 0"):
            s.set("line_follow.kp", -1)
        assert s.get("line_follow.kp") == 0.5

    @pytest.mark.parametrize("value", [float("nan"), float("inf"), float("-inf")])
    def test_a_number_that_is_not_finite_is_refused(self, value: float) -> None:
        """NaN passes any range check (its comparisons are all false): a NaN gain would stop
        the robot with no error. It is refused like any bad value, also without bounds."""
        s = Settings(defaults())
        with pytest.raises(ValueError, match=r"line_follow.kp: expected a finite number"):
            s.set("line_follow.kp", value)
        assert s.get("line_follow.kp") == 0.5
        for text in ("nan", "NaN", "Infinity", "-INF"):
            checked, error = Settings.option("line_follow.kp").parse_text(text)
            assert checked is None
            assert error is not None and error.startswith("expected a finite number, got ")

    def test_listeners_hear_changes_under_their_prefix(self) -> None:
        s = Settings(defaults())
        heard: list[tuple[str, object]] = []
        unwatch = s.watch("line_follow", lambda k, v: heard.append((k, v)))
        s.set("line_follow.kp", 0.6)
        s.set("fleet.period_s", 2.0)
        unwatch()
        s.set("line_follow.kd", 0.3)
        assert heard == [("line_follow.kp", 0.6)]

    def test_unknown_key_is_a_key_error_naming_it(self) -> None:
        with pytest.raises(KeyError, match=r"line_follow\.kq: unknown key"):
            Settings(defaults()).set("line_follow.kq", 1)

    def test_replace_reports_changed_keys(self) -> None:
        s = Settings(defaults())
        new = defaults()
        new["fleet"]["period_s"] = 3.0
        assert s.replace(new, source="f.toml") == ["fleet.period_s"]
        assert s.get("fleet.period_s") == 3.0

    def test_parse_text_reads_numbers_words_and_booleans(self) -> None:
        assert Settings.option("line_follow.kp").parse_text("0.6") == (0.6, None)
        assert Settings.option("logging.level").parse_text("debug") == ("debug", None)
        assert Settings.option("serial.baud").parse_text("fast")[1] is not None

    def test_check_normalises_a_value_and_changes_nothing(self) -> None:
        """check() says what would be stored (an integer gain as a float); apply() stores
        that and tells the listeners."""
        s = Settings(defaults())
        heard: list[str] = []
        s.watch("", lambda k, _v: heard.append(k))
        checked = s.check("line_follow.kp", 1)
        assert checked == Checked("line_follow.kp", 1.0)
        assert isinstance(checked.value, float)
        assert (s.get("line_follow.kp"), heard) == (0.5, [])
        assert s.apply(checked) == 1.0
        assert (s.get("line_follow.kp"), heard) == (1.0, ["line_follow.kp"])

    def test_check_refuses_a_limit_out_of_order_with_its_pair(self) -> None:
        """The orders are part of the one check: roi_bottom above roi_top."""
        with pytest.raises(ValueError, match=r"line_follow.roi_bottom: must be above"):
            Settings(defaults()).check("line_follow.roi_bottom", 0.1)

    def test_a_value_no_option_can_hold_is_refused_not_raised_on(self) -> None:
        """An integer past 64 bits is screened in check() (it used to be screened only on the
        tune.set path): a ValueError naming the key, nothing else."""
        s = Settings(defaults())
        with pytest.raises(ValueError, match=r"line_follow.lost_frames: integer out of range"):
            s.set("line_follow.lost_frames", 2**70)
        assert s.get("line_follow.lost_frames") == 20
