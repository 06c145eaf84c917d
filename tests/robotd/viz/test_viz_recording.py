"""``robotd sim --report DIR`` writes DIR/run.mcap: every built-in scenario's recording opens
with the ``mcap`` reader, each expected channel has messages, and times are the virtual clock's."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from mcap.reader import make_reader

from robotd.cli import main
from sim.scenario import builtin_names, load_scenario

pytestmark = pytest.mark.slow

EVERY_ROBOT = {"state": "robotd.state", "events": "robotd.events",
               "truth": "foxglove.PoseInFrame"}
BY_PROFILE = {
    "patrol": {"map": "foxglove.Grid", "scan": "foxglove.LaserScan",
               "particles": "foxglove.PosesInFrame", "path": "foxglove.SceneUpdate",
               "pose": "foxglove.PoseInFrame", "odom": "foxglove.PoseInFrame",
               "tf": "foxglove.FrameTransform",
               "localisation": "robotd.localisation"},
    "laundry": {"camera": "foxglove.CompressedImage", "line": "robotd.line",
                "beacons": "robotd.beacons"},
    "vacuum": {"dock": "robotd.dock", "odom": "foxglove.PoseInFrame"},
    "square": {"odom": "foxglove.PoseInFrame"},
    "delivery": {"map": "foxglove.Grid", "scan": "foxglove.LaserScan",
                 "particles": "foxglove.PosesInFrame", "pose": "foxglove.PoseInFrame",
                 "path": "foxglove.SceneUpdate"},
    "cabinet": {"map": "foxglove.Grid", "scan": "foxglove.LaserScan",
                "particles": "foxglove.PosesInFrame", "pose": "foxglove.PoseInFrame",
                "cabinet/links_open": "foxglove.SceneUpdate",
                "cabinet/path": "foxglove.SceneUpdate"},
    "survey": {"map": "foxglove.Grid", "scan": "foxglove.LaserScan",
               "pose": "foxglove.PoseInFrame", "odom": "foxglove.PoseInFrame",
               "tf": "foxglove.FrameTransform"},
}
BY_SCENARIO = {"delivery": {"delivery/box": "robotd.delivery.box"}}  # the box opens there
LONG = {"map-depot": "6-8 minutes of exploring: tests/robotd/test_mapping_mcap.py records 90 s "
                     "of the same survey and reads its /scan and /odom back",
        "laundry-console": "made for an outside fleet server (--fleet-url): alone it ends at base "
                           "in 0.5 s, before its first camera frame; its robot and channels are "
                           "laundry's, recorded by the laundry scenarios here"}
_WALL_EPOCH_NS = 10**18  # 2001-09-09: any wall-clock time is past it, virtual times are not


def _expected(name: str) -> dict[str, str]:
    scenario = load_scenario(name)
    many = len(scenario.robots) > 1
    topics = {"/world/map": "foxglove.Grid"}
    for spec in scenario.robots:
        prefix = f"/{spec.name}/" if many else "/"
        own = {**EVERY_ROBOT, **BY_PROFILE.get(scenario.profile, {}),
               **BY_SCENARIO.get(name, {})}
        topics |= {prefix + short: schema for short, schema in own.items()}
    return topics


@pytest.mark.parametrize("name", [
    pytest.param(n, marks=pytest.mark.skip(reason=LONG[n])) if n in LONG else n
    for n in builtin_names()])
def test_run_mcap_has_every_channel_on_virtual_time(name: str, tmp_path: Path) -> None:
    """Each expected channel has messages in its schema, between 0 and the run's end."""
    code = main(["sim", name, "--quiet", "--report", str(tmp_path)])
    assert code in (0, 1)  # a scenario's own verdict is its tests' business
    with (tmp_path / "run.mcap").open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None and summary.statistics is not None
    counts = summary.statistics.channel_message_counts
    got = {ch.topic: (summary.schemas[ch.schema_id].name, counts.get(cid, 0))
           for cid, ch in summary.channels.items()}
    for topic, schema in _expected(name).items():
        assert topic in got, f"{name}: no channel {topic} (have {sorted(got)})"
        assert got[topic][0] == schema, f"{name}: {topic} is {got[topic][0]}"
        assert got[topic][1] > 0, f"{name}: no message on {topic}"
    start, end = summary.statistics.message_start_time, summary.statistics.message_end_time
    assert 0 <= start <= end < _WALL_EPOCH_NS
    last = json.loads((tmp_path / "events.jsonl").read_text().splitlines()[-1])
    assert end <= (float(last["t"]) + 1.0) * 1e9, "no message after the run's virtual end"


@pytest.mark.parametrize(("name", "seed"), [("square", 3), ("nav", 1), ("docking", 1)])
def test_recording_does_not_change_the_run(name: str, seed: int, tmp_path: Path) -> None:
    """The same run with and without run.mcap: the same events, field for field."""
    import argparse

    from sim import runner, vclock
    from sim.console import SimConsole

    scenario = load_scenario(name)
    runs = []
    for report in (None, tmp_path / "report"):
        if report is not None:
            report.mkdir()
        work = tmp_path / f"work-{len(runs)}"
        work.mkdir()
        args = argparse.Namespace(scenario=name, seed=seed, realtime=False, speed=None,
                                  report=str(report) if report else None, quiet=True,
                                  socket=None, config=None, mcu="fake", viz=False)
        result = vclock.run(runner._run(args, scenario, SimConsole(quiet=True), work))
        assert not isinstance(result, int)
        runs.append(result.events)
    assert (tmp_path / "report" / "run.mcap").stat().st_size > 0
    assert runs[0] == runs[1]
