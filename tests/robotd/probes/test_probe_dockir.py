"""``robotd probe dockir --replay``: a Flipper capture through the real decoder."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from robotd.probes import dockir

DATA = Path(__file__).parents[2] / "drivers" / "data" / "roomba_dock.ir"
ROBOTD = Path(sys.executable).with_name("robotd")


class TestReplay:
    def test_json_lists_each_code_with_its_count_and_the_counters(
            self, capsys: pytest.CaptureFixture[str]) -> None:
        """--replay --json prints one object: codes with names and counts, the error counters."""
        assert dockir.main(["--replay", str(DATA), "--json"]) == 0
        report = json.loads(capsys.readouterr().out)
        assert report["signals"] == 6
        assert {c["code"]: c["count"] for c in report["codes"]} == {
            161: 3, 162: 2, 164: 3, 168: 3, 172: 2, 173: 1}
        assert {c["code"]: c["name"] for c in report["codes"]}[172] == "green_buoy + red_buoy"
        counters = report["counters"]
        assert (counters["half_codes"], counters["glitches"], counters["collisions"]) == (1, 1, 0)
        assert counters["unknown_codes"] == 0
        assert len(report["skipped"]) == 1 and ":44:" in report["skipped"][0]
        assert [s["codes"] for s in report["by_signal"]][-1] == []

    def test_text_output_names_codes_and_errors(self, capsys: pytest.CaptureFixture[str]) -> None:
        """Without --json: a line per code and one with the error counters."""
        assert dockir.main(["--replay", str(DATA)]) == 0
        out = capsys.readouterr().out
        assert "164  x3    green_buoy" in out
        assert "half codes 1" in out

    def test_a_malformed_file_is_named_by_line_and_exits_2(
            self, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
        """A bad data word: FILE:LINE: message on stderr, exit 2, nothing on stdout."""
        bad = tmp_path / "bad.ir"
        bad.write_text("Filetype: IR signals file\nVersion: 1\nname: x\ntype: raw\n"
                       "frequency: 38000\nduty_cycle: 0.33\ndata: 3000 -5\n")
        assert dockir.main(["--replay", str(bad), "--json"]) == 2
        captured = capsys.readouterr()
        assert captured.out == ""
        assert captured.err.startswith(f"{bad}:7: signal 'x': data must be durations")

    def test_a_missing_file_exits_2(self, tmp_path: Path,
                                    capsys: pytest.CaptureFixture[str]) -> None:
        """A file that is not there: a clear line and exit 2."""
        assert dockir.main(["--replay", str(tmp_path / "none.ir")]) == 2
        assert "cannot read" in capsys.readouterr().err

    @pytest.mark.skipif(not ROBOTD.exists(), reason="robotd console script not installed")
    def test_robotd_probe_dockir_is_a_subcommand(self) -> None:
        """`robotd probe dockir --replay FILE --json` runs through the CLI."""
        proc = subprocess.run([str(ROBOTD), "probe", "dockir", "--replay", str(DATA), "--json"],
                              capture_output=True, text=True, timeout=60, check=False)
        assert proc.returncode == 0, proc.stderr
        assert json.loads(proc.stdout)["signals"] == 6
