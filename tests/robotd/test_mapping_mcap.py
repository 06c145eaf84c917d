"""``robotd map --from-log run.mcap``: our own recordings as mapping input (issue 30): the
survey's scans and odometry recorded by ``robotd sim --report`` (the live view's recorder) are
mapped offline with the relation error against the recorded true poses; a cut recording is
read as far as it goes and the rest counted as skipped."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from hal.occupancy_map import OCCUPIED, read_map_yaml
from robotd.cli import main
from robotd.mapping.mcap_log import read_mcap, schema_fields, wire_fields
from sim.scenario import builtins


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """90 s of the survey exploring the depot, recorded (run.mcap)."""
    tmp = tmp_path_factory.mktemp("survey-rec")
    source = Path(str(builtins()["map-depot"])) / "map-depot.toml"
    text = source.read_text(encoding="utf-8")
    text = text.replace('"../../../maps/depot.yaml"',
                        json.dumps(str((source.parent / "../../../maps/depot.yaml").resolve())))
    text = text[:text.index("[[script]]")] + "[success]\ntime_limit_s = 90\n"
    scenario = tmp / "survey-90s.toml"
    scenario.write_text(text, encoding="utf-8")
    main(["sim", str(scenario), "--quiet", "--report", str(tmp / "report")])
    return tmp / "report" / "run.mcap"


def test_a_recording_maps_as_the_live_survey_did(recording: Path, tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    """Standing scans with their odometry: a map, and the relation error against the
    recorded truth within 5 cm and 1 deg over all key-scan pairs."""
    code = main(["map", "--from-log", str(recording), "--out", str(tmp_path / "made")])
    out = capsys.readouterr().out
    assert code == 0, out
    assert "unreadable lines skipped: 0" in out
    found = re.search(r"all key-scan pairs, \d+\): ([\d.]+) cm, ([\d.]+) deg", out)
    assert found, out
    assert float(found[1]) <= 5.0 and float(found[2]) <= 1.0
    grid = read_map_yaml(tmp_path / "made.yaml")
    assert (grid.cells == OCCUPIED).sum() > 500


def test_a_cut_recording_is_read_as_far_as_it_goes(recording: Path, tmp_path: Path) -> None:
    data = recording.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) * 2 // 3])
    whole, part = read_mcap(recording), read_mcap(cut)
    assert part.skipped and 0 < len(part.scans) < len(whole.scans)


def test_the_wire_reader_takes_a_messages_fields_and_refuses_a_cut_one() -> None:
    """Field 1 varint 150, field 2 'hi', field 3 a double: read back; cut short: refused."""
    message = bytes([0x08, 0x96, 0x01, 0x12, 0x02]) + b"hi" + bytes([0x19]) + \
        (1.5).hex().encode()[:0] + bytes.fromhex("000000000000f83f")
    fields = wire_fields(message)
    assert fields[1] == [150] and fields[2] == [b"hi"] and len(fields[3][0]) == 8
    with pytest.raises(ValueError, match="cut short"):
        wire_fields(message[:-3])
    assert schema_fields(b"") == {}


def test_the_survey_shows_the_live_view_its_scans_pose_and_growing_map(recording: Path
                                                                      ) -> None:
    """What the recorder wrote of the survey: /scan, /pose, /map (the growing map's walls),
    /odom and /tf, each with messages (the channels test of every built-in leaves the long
    map-depot out)."""
    from mcap.reader import make_reader

    with recording.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None and summary.statistics is not None
    counts = summary.statistics.channel_message_counts
    got = {ch.topic: counts.get(cid, 0) for cid, ch in summary.channels.items()}
    for topic in ("/scan", "/pose", "/map", "/odom", "/tf"):
        assert got.get(topic, 0) > 0, f"no message on {topic} (have {sorted(got)})"
