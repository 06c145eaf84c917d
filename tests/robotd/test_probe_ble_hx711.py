"""``robotd probe ble`` and ``robotd probe hx711`` on the simulator (--sim): figures and JSON."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import pytest

from robotd.probes import ble, hx711
from sim import vclock


def _args(module: object, argv: list[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    module.add_arguments(parser)  # type: ignore[attr-defined]
    return parser.parse_args(argv)


class TestBleProbe:
    def test_json_reports_the_simulated_beacon(self, capsys: pytest.CaptureFixture[str]) -> None:
        """--sim --json prints one object with the beacon, its RSSI and distance figures."""
        code = vclock.run(ble.run(_args(ble, ["--sim", "--json", "--duration-s", "5"])))
        report = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
        assert code == 0
        (beacon,) = report["beacons"]
        assert beacon["minor"] == 103 and beacon["sightings"] > 30
        assert 1.0 < beacon["distance_m"] < 3.5
        assert report["scanner"]["malformed"] == 0

    def test_no_matching_beacon_exits_1(self, capsys: pytest.CaptureFixture[str]) -> None:
        """Filtering on a UUID nobody advertises finds nothing: exit 1 with a message."""
        argv = ["--sim", "--duration-s", "3", "--uuid", "e2c56db5-dffb-48d2-b060-d0f5a71096e0"]
        assert vclock.run(ble.run(_args(ble, argv))) == 1
        assert "no matching iBeacon" in capsys.readouterr().err

    def test_bad_uuid_is_a_usage_error(self, capsys: pytest.CaptureFixture[str]) -> None:
        """A --uuid that is not a UUID exits 2 naming it."""
        assert vclock.run(ble.run(_args(ble, ["--sim", "--uuid", "room-103"]))) == 2
        assert "room-103" in capsys.readouterr().err

    @pytest.mark.parametrize(("option", "value"), [
        ("--path-loss-exponent", "0"), ("--path-loss-exponent", "nan"),
        ("--path-loss-exponent", "0.001"), ("--duration-s", "0"), ("--duration-s", "-5")])
    def test_unusable_numbers_are_usage_errors(self, option: str, value: str,
                                               capsys: pytest.CaptureFixture[str]) -> None:
        """n outside the config's range or a duration <= 0 exits 2 naming the option."""
        assert vclock.run(ble.run(_args(ble, ["--sim", f"{option}={value}"]))) == 2
        assert option in capsys.readouterr().err


class TestHx711Probe:
    def test_calibration_prints_the_factor_for_toml(
            self, capsys: pytest.CaptureFixture[str]) -> None:
        """--known-kg tares, calibrates and reports a factor near the cell's true scale."""
        argv = ["--sim", "--json", "--known-kg", "2.0"]
        assert vclock.run(hx711.run(_args(hx711, argv))) == 0
        report = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
        assert abs(report["calibration_factor"] / 103_500 - 1) < 0.01
        assert abs(report["kg"] - 2.0) < 0.02
        assert report["tare_offset"] == pytest.approx(-48_213, abs=300)

    def test_text_output_has_the_toml_lines(self, capsys: pytest.CaptureFixture[str]) -> None:
        """Without --json the probe prints the [hx711] lines to paste into robotd.toml."""
        assert vclock.run(hx711.run(_args(hx711, ["--sim", "--known-kg", "1.5"]))) == 0
        out = capsys.readouterr().out
        assert "[hx711]" in out and "calibration_factor = " in out

    def test_missing_gpio_is_reported(self, capsys: pytest.CaptureFixture[str]) -> None:
        """On a machine without lgpio or a GPIO chip the probe exits 1 and says why."""
        code = vclock.run(hx711.run(_args(hx711, ["--chip", "63"])))
        assert code == 1
        assert "hx711:" in capsys.readouterr().err

    def test_saturated_input_ends_with_the_counts_instead_of_hanging(
            self, capsys: pytest.CaptureFixture[str]) -> None:
        """A load beyond the ADC's range (or a loose bridge wire) gives only saturated codes:
        the probe exits 1 naming them rather than waiting for a reading forever."""
        code = vclock.run(hx711.run(_args(hx711, ["--sim", "--sim-kg", "1000"])))
        assert code == 1
        assert "saturated" in capsys.readouterr().err

    @pytest.mark.parametrize("argv", [
        ["--known-kg", "0"], ["--known-kg", "-2"], ["--known-kg", "nan"], ["--sim-kg", "nan"],
        ["--readings", "0"], ["--wait-s", "-1"]])
    def test_unusable_numbers_are_usage_errors(self, argv: list[str],
                                               capsys: pytest.CaptureFixture[str]) -> None:
        """A calibration mass that is not > 0 (0 used to skip calibration silently), a NaN
        load or no readings exit 2 naming the option, before the technician is asked anything."""
        assert vclock.run(hx711.run(_args(hx711, ["--sim", *argv]))) == 2
        assert argv[0] in capsys.readouterr().err

    def test_a_config_rate_the_chip_cannot_run_at_is_a_usage_error(
            self, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
        """hx711.sps = 40: no HX711 runs at it: exit 2, naming the line and the two rates."""
        config = tmp_path / "robotd.toml"
        config.write_text("[hx711]\nsps = 40\n")
        assert vclock.run(hx711.run(_args(hx711, ["--sim", "--config", str(config)]))) == 2
        assert "robotd.toml:2: hx711.sps: expected one of 10, 80, got 40" \
            in capsys.readouterr().err
