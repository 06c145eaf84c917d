"""The TOML loader: every problem reported with file, line and section.key."""

from __future__ import annotations

from pathlib import Path

import pytest

from robotd.config import ConfigError, load_config, load_config_text
from robotd.config.loader import defaults


class TestLoadConfigText:
    def test_fills_defaults_for_missing_keys(self) -> None:
        """A file naming one key gets every other key at its default."""
        values = load_config_text('[robot]\nname = "r7"\n', "x.toml")
        assert values["robot"]["name"] == "r7"
        assert values["serial"]["baud"] == 115200
        assert values["line_follow"]["fps"] == 13.0

    def test_reports_wrong_type_unknown_key_and_syntax_error_each_on_its_line(self) -> None:
        """Three different problems give three lines, each naming its line and key."""
        text = "[serial]\nbaud = \"fast\"\ncolour = 3\n\n[line_follow]\nkp = = 0.4\n"
        with pytest.raises(ConfigError) as info:
            load_config_text(text, "bad.toml")
        lines = str(info.value).splitlines()
        assert lines == [
            "bad.toml:2: serial.baud: expected an integer, got a string ('fast')",
            lines[1],
            "bad.toml:6: line_follow.kp: TOML syntax error: Invalid value",
        ]
        assert lines[1].startswith("bad.toml:3: serial.colour: unknown key")

    def test_something_never_closed_is_reported_on_the_last_line_with_text(self) -> None:
        """A list never closed ends the document: the error names the line where the reader
        ran out and its key, not an unknown place."""
        text = '[serial]\nport = "/dev/ttyACM0"\nbaud = [9600,\n\n'
        with pytest.raises(ConfigError) as info:
            load_config_text(text, "open.toml")
        assert str(info.value) == (
            "open.toml:3: serial.baud: TOML syntax error: Invalid value (at end of document)")

    def test_nan_in_the_file_is_an_error_on_its_line(self) -> None:
        text = "[line_follow]\nkp = nan\n"
        with pytest.raises(ConfigError) as info:
            load_config_text(text, "nan.toml")
        assert str(info.value) == "nan.toml:2: line_follow.kp: expected a finite number, got nan"

    def test_unknown_section_suggests_the_close_one(self) -> None:
        """A misspelt section is named and the likely one suggested."""
        with pytest.raises(ConfigError, match=r"x.toml:1: serail: unknown section .*'serial'"):
            load_config_text("[serail]\nport = 'x'\n", "x.toml")

    def test_bounds_are_checked(self) -> None:
        """A value out of its bounds says the bound."""
        with pytest.raises(ConfigError, match=r"docking.battery_threshold_pct: must be <= 100"):
            load_config_text("[docking]\nbattery_threshold_pct = 150\n", "x.toml")

    def test_choices_are_checked(self) -> None:
        with pytest.raises(ConfigError, match=r"serial.framing: expected one of 'crc', 'plain'"):
            load_config_text("[serial]\nframing = 'crc16'\n", "x.toml")

    def test_dotted_keys_at_top_level_are_located(self) -> None:
        """``serial.baud = ...`` outside a table is found on its line."""
        with pytest.raises(ConfigError, match=r"x.toml:2: serial.baud: expected an integer"):
            load_config_text("# top\nserial.baud = 1.5\n", "x.toml")

    def test_integer_given_for_float_is_accepted(self) -> None:
        assert load_config_text("[line_follow]\nkp = 1\n")["line_follow"]["kp"] == 1.0


class TestLoadConfig:
    def test_missing_file_is_one_clear_problem(self, tmp_path: Path) -> None:
        with pytest.raises(ConfigError, match=r"nope.toml: file: cannot read"):
            load_config(tmp_path / "nope.toml")

    def test_overrides_file_wins_over_the_main_file(self, tmp_path: Path) -> None:
        main = tmp_path / "robotd.toml"
        main.write_text("[line_follow]\nkp = 0.2\nki = 0.1\n")
        over = tmp_path / "overrides.toml"
        over.write_text("[line_follow]\nkp = 0.7\n")
        values = load_config(main, overrides=over)
        assert values["line_follow"]["kp"] == 0.7
        assert values["line_follow"]["ki"] == 0.1

    def test_every_default_passes_its_own_check(self) -> None:
        """The schema's defaults are valid values of their own options."""
        from robotd.config.sections import SECTIONS

        for name, section in SECTIONS.items():
            for option in section.options:
                _, error = option.check(defaults()[name][option.key])
                assert error is None, f"{name}.{option.key}: {error}"


class TestNamesTheFileGives:
    def test_an_empty_or_odd_section_or_key_name_keeps_the_problem_line_readable(self) -> None:
        """``[""]`` and ``"a:b" = 1`` are valid TOML: the problem line quotes the name (its
        colons escaped) so it still reads ``PATH:LINE: section.key: message`` (found by the
        config loader fuzz test)."""
        with pytest.raises(ConfigError) as caught:
            load_config_text('[""]\nx = 1\n[robot]\n"a:b" = 1\n', "r.toml")
        assert [str(p) for p in caught.value.problems] == [
            'r.toml:1: "": unknown section',
            'r.toml:4: robot."a\\u003ab": unknown key (known: name, profile, state_dir)',
        ]


class TestDidYouMean:
    def test_a_key_wrong_only_in_case_is_named(self) -> None:
        """``Kp`` for ``kp``: difflib's ratio is too low for a two-letter key; case is not."""
        with pytest.raises(ConfigError,
                           match=r"line_follow.Kp: unknown key \(did you mean 'kp'\?\)"):
            load_config_text("[line_follow]\nKp = 1\n", "r.toml")
