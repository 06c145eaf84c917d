"""Limits that only make sense in order: refused from the file and from live tuning alike."""

from __future__ import annotations

from pathlib import Path

import pytest

from robotd.config import ConfigError, load_config, load_config_text
from robotd.config.loader import defaults
from robotd.config.settings import Settings


class TestFromTheFile:
    def test_a_lower_limit_above_the_upper_is_reported_at_the_upper_ones_line(self) -> None:
        """[weight] min 20, max 1: check-config says so instead of the daemon refusing later."""
        with pytest.raises(ConfigError) as info:
            load_config_text("[weight]\nmin_kg = 20\nmax_kg = 1\n", "w.toml")
        assert str(info.value) == ("w.toml:3: weight.max_kg: must be above weight.min_kg (20), "
                                   "got 1")

    def test_a_band_out_of_order_against_a_default_is_reported(self) -> None:
        """Only band_forward_px in the file, above the default gentle band (80)."""
        with pytest.raises(ConfigError) as info:
            load_config_text("[line_follow]\nband_forward_px = 200\n", "b.toml")
        assert "line_follow.band_gentle_px: must be above line_follow.band_forward_px (200)" \
            in str(info.value)

    def test_an_integer_with_a_few_allowed_values_names_them(self) -> None:
        """The HX711's RATE pin gives 10 or 80 SPS: 40 is refused by check-config already."""
        with pytest.raises(ConfigError) as info:
            load_config_text("[hx711]\nsps = 40\n", "h.toml")
        assert str(info.value) == "h.toml:2: hx711.sps: expected one of 10, 80, got 40"

    def test_equal_limits_pass_where_the_order_is_not_strict(self) -> None:
        """A restart delay that starts at its cap is a fixed delay: allowed."""
        values = load_config_text(
            "[supervisor]\nrestart_base_s = 5\nrestart_max_s = 5\n", "s.toml")
        assert values["supervisor"]["restart_max_s"] == 5

    def test_overrides_that_break_the_order_name_the_overrides_file(self, tmp_path: Path
                                                                    ) -> None:
        main = tmp_path / "robotd.toml"
        main.write_text("[line_follow]\nroi_top = 0.2\n")
        over = tmp_path / "overrides.toml"
        over.write_text("[line_follow]\nroi_bottom = 0.1\n")
        with pytest.raises(ConfigError) as info:
            load_config(main, overrides=over)
        assert str(info.value).startswith(f"{over}:2: line_follow.roi_bottom: must be above")


class TestLiveTuning:
    def test_a_value_that_breaks_the_order_is_refused_and_not_applied(self) -> None:
        """tune set band_forward_px 200 (gentle is 80): refused, naming the other limit."""
        settings = Settings(defaults())
        with pytest.raises(ValueError, match=r"line_follow.band_forward_px: must be below "
                                             r"line_follow.band_gentle_px \(80\), got 200"):
            settings.set("line_follow.band_forward_px", 200.0)
        assert settings.get("line_follow.band_forward_px") == 30.0

    def test_the_top_of_the_scanned_band_cannot_pass_its_bottom(self) -> None:
        settings = Settings(defaults())
        with pytest.raises(ValueError, match=r"roi_top: must be below line_follow\.roi_bottom"):
            settings.set("line_follow.roi_top", 0.9)

    def test_a_range_widens_by_moving_the_outer_limit_first(self) -> None:
        """min 12 with max 10 is refused; max 20 then min 12 is taken."""
        settings = Settings(defaults())
        with pytest.raises(ValueError, match=r"weight\.min_kg: must be below weight\.max_kg"):
            settings.set("weight.min_kg", 12.0)
        settings.set("weight.max_kg", 20.0)
        settings.set("weight.min_kg", 12.0)
        assert (settings.get("weight.min_kg"), settings.get("weight.max_kg")) == (12.0, 20.0)

    def test_large_numbers_are_shown_in_full(self) -> None:
        """A range error shows 8388607, not 8.38861e+06."""
        settings = Settings(defaults())
        with pytest.raises(ValueError, match=r"must be <= 8388607, got 99999999$"):
            settings.set("hx711.tare_offset", 99999999)
