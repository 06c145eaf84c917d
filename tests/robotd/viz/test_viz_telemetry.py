"""The telemetry port and its Foxglove adapter: no-op when off, decimated, on the given clock,
bad data counted (never raised), recordings that rotate and are pruned."""

from __future__ import annotations

import json
from datetime import UTC, datetime, timedelta
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader

from hal.readings import LidarScan
from hal.telemetry import NULL_TELEMETRY, Telemetry
from robotd.config.loader import defaults
from robotd.config.settings import Settings
from robotd.viz.recorder import RotatingRecorder
from robotd.viz.runtime import open_daemon_viz
from robotd.viz.session import VizSession
from robotd.viz.telemetry import FoxgloveTelemetry
from sim.viz_feed import SIM_PERIODS


class FakeClock:
    def __init__(self) -> None:
        self.t_ns = 0

    def __call__(self) -> int:
        return self.t_ns


def _scan() -> LidarScan:
    angles = np.linspace(-np.pi, np.pi, 450, endpoint=False)
    ranges = np.full(450, 2.0)
    ranges[::7] = np.nan
    return LidarScan(angles, ranges, np.full(450, 200, dtype=np.uint8), t_s=0.0)


def _read(path: Path) -> dict[str, list[int]]:
    """Log times (ns) per topic."""
    out: dict[str, list[int]] = {}
    with path.open("rb") as f:
        for _schema, channel, message in make_reader(f).iter_messages():
            out.setdefault(channel.topic, []).append(message.log_time)
    return out


def test_both_implementations_are_telemetry() -> None:
    """The no-op and the adapter both satisfy the port; only the adapter is enabled."""
    session = VizSession()
    try:
        assert isinstance(NULL_TELEMETRY, Telemetry) and not NULL_TELEMETRY.enabled
        feed = session.telemetry("r")
        assert isinstance(feed, Telemetry) and feed.enabled
    finally:
        session.close()


async def test_nothing_is_built_without_a_sink() -> None:
    """No server and no recording: every call returns without making a message."""
    session = VizSession()
    try:
        feed = session.telemetry("r")
        feed.scan("scan", _scan())
        feed.values("state", state="idle")
        feed.image("camera", np.zeros((24, 32), dtype=np.uint8))
        assert feed.published == 0 and feed.failed == 0
    finally:
        session.close()


def test_recording_is_on_the_given_clock_and_decimated(tmp_path: Path) -> None:
    """Log times are the clock's; images at most every 1 s, samples every 0.1 s, scans
    and values every call."""
    session = VizSession()
    clock = FakeClock()
    feed = FoxgloveTelemetry(session.context, clock_ns=clock)
    session.record(tmp_path / "run.mcap")
    image = np.zeros((24, 32, 3), dtype=np.uint8)
    for i in range(20):  # 2 s at 10 Hz
        clock.t_ns = 1_000_000_000 + i * 100_000_000
        feed.image("camera", image, marks=[(5, 5)])
        feed.scan("scan", _scan())
        feed.pose("pose", (1.0, 2.0, 0.5), child_frame="base_link")
        feed.values("state", state="idle")
        feed.sample("line", error_px=1.0)
        clock.t_ns += 50_000_000  # a second sample 50 ms later: too soon, dropped
        feed.sample("line", error_px=2.0)
    session.close()
    topics = _read(tmp_path / "run.mcap")
    assert len(topics["/scan"]) == 20
    assert len(topics["/camera"]) == 2
    assert topics["/pose"][0] == 1_000_000_000
    assert len(topics["/tf"]) == 20
    assert len(topics["/state"]) == 20  # values: every one
    assert len(topics["/line"]) == 20  # sample: at most one per 0.1 s


def test_a_session_s_periods_replace_the_defaults(tmp_path: Path) -> None:
    """The simulator's session (``SIM_PERIODS``): a camera image every 2 s, other kinds as
    before; a robot's feed takes its session's periods."""
    session = VizSession(periods=SIM_PERIODS)
    clock = FakeClock()
    session.record(tmp_path / "run.mcap")
    feed = session.telemetry("r")
    feed.clock_ns = clock
    image = np.zeros((24, 32, 3), dtype=np.uint8)
    for i in range(60):  # 6 s at 10 Hz
        clock.t_ns = i * 100_000_000
        feed.image("camera", image)
        feed.sample("line", error_px=1.0)
    session.close()
    topics = _read(tmp_path / "run.mcap")
    assert SIM_PERIODS["image"] == 2.0
    assert topics["/camera"] == [0, 2_000_000_000, 4_000_000_000]
    assert len(topics["/line"]) == 60


def test_a_recording_alone_holds_values_until_the_tick(tmp_path: Path) -> None:
    """No server: a robot's JSON values wait for the session's tick (or close), then go out
    in the order they came, each at the time of its call; at most 256 wait."""
    session = VizSession()
    clock = FakeClock()
    session.record(tmp_path / "run.mcap")
    feed = session.telemetry("r")
    feed.clock_ns = clock
    for i in range(10):
        clock.t_ns = i * 1_000_000
        feed.values("state", state=f"s{i}")
    assert feed.hold and feed.published == 0
    session.tick()
    assert feed.published == 10
    for i in range(300):
        feed.values("events", n=i)
    assert feed.published == 10 + 256  # a full hold is sent without waiting
    clock.t_ns = 42
    feed.values("events", n=300)
    session.close()
    with (tmp_path / "run.mcap").open("rb") as f:
        sent = [(c.topic, m.log_time, json.loads(m.data))
                for _s, c, m in make_reader(f).iter_messages(log_time_order=False)]
    states = [(t, d["state"]) for topic, t, d in sent if topic == "/state"]
    assert states[:10] == [(i * 1_000_000, f"s{i}") for i in range(10)]
    assert [d["n"] for topic, _t, d in sent if topic == "/events"] == list(range(301))


def test_a_live_viewer_gets_values_at_once() -> None:
    """With a server (started before or after the feed was made) nothing is held."""
    session = VizSession()
    try:
        early = session.telemetry("a")
        assert early.hold
        early.values("state", state="idle")  # no sink yet: dropped, not held
        session.serve("127.0.0.1", 0)
        late = session.telemetry("b")
        assert not early.hold and not late.hold
    finally:
        session.close()


def test_several_robots_have_their_own_topics_and_frames(tmp_path: Path) -> None:
    """With many robots, topics sit under /<robot>/ and frames under <robot>/ (map shared)."""
    session = VizSession(many=True)
    session.record(tmp_path / "run.mcap")
    a = session.telemetry("a")
    assert a.topic("scan") == "/a/scan"
    assert a.frame("base_link") == "a/base_link" and a.frame("map") == "map"
    session.close()


def test_values_are_json_whatever_the_caller_passes(tmp_path: Path) -> None:
    """Values are strict JSON: NaN is null, numpy's numbers are numbers, keys that are not
    strings are strings, and what JSON has no type for is its str; a value too large for
    JSON's encoder is counted as failed, and the next one still goes out."""
    session = VizSession()
    session.record(tmp_path / "run.mcap")
    clock = FakeClock()
    feed = FoxgloveTelemetry(session.context, clock_ns=clock)
    clock.t_ns = 1_500_000_000
    feed.values("v", nan=float("nan"), f=np.float32(0.5), i=np.int64(7), a=np.arange(3),
                keys={1: "one"}, path=tmp_path / "x", flag=np.bool_(True))
    feed.values("v", big=2**70)
    feed.values("v", after=1)
    session.close()
    with (tmp_path / "run.mcap").open("rb") as f:
        sent = [json.loads(m.data) for _s, _c, m in make_reader(f).iter_messages()]
    assert sent == [{"t_s": 1.5, "nan": None, "f": 0.5, "i": 7, "a": [0, 1, 2],
                     "keys": {"1": "one"}, "path": str(tmp_path / "x"), "flag": True},
                    {"t_s": 1.5, "after": 1}]
    assert feed.failed == 1


async def test_bad_data_is_counted_not_raised(tmp_path: Path) -> None:
    """A frame OpenCV cannot read or one topic used with two kinds is counted, not raised."""
    session = VizSession()
    session.record(tmp_path / "run.mcap")
    feed = session.telemetry("r")
    feed.image("camera", np.zeros((2, 2, 7), dtype=np.uint8))
    feed.values("scan", x=1)
    feed.scan("scan", _scan())  # "scan" is a JSON channel now: the scan cannot go there
    session.close()
    assert feed.failed >= 1


def test_recordings_rotate_and_the_oldest_are_deleted(tmp_path: Path) -> None:
    """Past max_bytes a new file begins; only ``keep`` files stay."""
    session = VizSession()
    start = datetime(2026, 1, 1, tzinfo=UTC)
    clock = FakeClock()
    feed = FoxgloveTelemetry(session.context, clock_ns=clock)
    recorder = RotatingRecorder(tmp_path / "viz", session.context, max_bytes=100_000, keep=2,
                                wall_clock=lambda: start + timedelta(seconds=clock.t_ns / 1e9))
    session.record_rotating(recorder)
    noise = np.random.default_rng(1)
    for i in range(40):
        clock.t_ns = i * 1_000_000_000
        feed.image("camera", noise.integers(0, 255, (120, 160, 3), dtype=np.uint8))
        if recorder._writer is not None:
            recorder._writer.flush()
        session.tick()
    session.close()
    files = sorted((tmp_path / "viz").glob("robotd-*.mcap"))
    assert recorder.files_started > 2
    assert len(files) == 2
    for f in files:
        _read(f)  # each one a complete MCAP file


def test_viz_off_is_no_session(tmp_path: Path) -> None:
    """``[viz]`` as shipped (off, not recording): no session, nothing opened."""
    settings = Settings(defaults())
    assert open_daemon_viz(settings, tmp_path, lambda: datetime.now(UTC)) is None


@pytest.mark.parametrize("record", [True, False])
def test_a_taken_port_on_the_robot_is_logged_and_the_robot_runs(tmp_path: Path,
                                                                record: bool) -> None:
    """``robotd run``: a live view that cannot serve is no reason to stop the robot."""
    import socket

    with socket.socket() as other:
        other.bind(("127.0.0.1", 0))
        other.listen()
        values = defaults()
        values["viz"] |= {"enabled": True, "port": other.getsockname()[1], "record": record}
        session = open_daemon_viz(Settings(values), tmp_path, lambda: datetime.now(UTC))
    if record:
        assert session is not None and session.server is None and session.rotating is not None
        session.close()
        assert list((tmp_path / "viz").glob("*.mcap"))
    else:
        assert session is None
