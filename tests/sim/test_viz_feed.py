"""The simulator's feed: true poses at 5 Hz at the instants they were sampled, a second at a
time into a recording alone, and as they come to a live viewer."""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from pathlib import Path

from mcap.reader import make_reader

from robotd.viz.session import VizSession
from sim.viz_feed import SimFeed
from sim.world.floor_plan import World
from sim.world.geometry import segments_array


@dataclass(frozen=True)
class Point:
    t_s: float
    x_m: float
    y_m: float
    heading_rad: float


def _truth_times(path: Path) -> list[int]:
    with path.open("rb") as f:
        return [m.log_time for _s, c, m in make_reader(f).iter_messages()
                if c.topic == "/truth"]


def _run(session: VizSession, ticks: int) -> tuple[SimFeed, list[Point]]:
    """The runner's way: a sample at the start, then a sample and a feed tick every 0.1 s."""
    track: list[Point] = [Point(0.0, 0.0, 0.0, 0.0)]
    feed = SimFeed(session, World(4.0, 3.0, segments_array([])), {"r": track})
    for k in range(1, ticks + 1):
        t_s = sum([0.1] * k)  # as the loop's time adds up: not exactly k / 10
        track.append(Point(t_s, 0.1 * k, 0.0, 0.0))
        feed.tick()
    return feed, track


def test_a_recording_gets_every_other_sample_at_its_own_time(tmp_path: Path) -> None:
    """2.5 s of ticks: the poses go out a second at a time, 0.2 s apart from the start pose
    on, at their samples' times; the last ones by ``flush`` at the end of the run."""
    session = VizSession()
    session.record(tmp_path / "run.mcap")
    feed, track = _run(session, 25)
    assert session.telemetry("r").published == 11  # 0.0 .. 2.0 s, after the ticks at 1 and 2 s
    feed.flush()
    assert session.telemetry("r").published == 13
    session.close()
    times = _truth_times(tmp_path / "run.mcap")
    assert times == [round(p.t_s * 1e9) for p in track[0::2]]
    assert all(round((b - a) / 1e6) == 200 for a, b in itertools.pairwise(times))


def test_a_live_viewer_gets_the_latest_pose_every_other_tick(tmp_path: Path) -> None:
    """With a server: each pose as it comes (the one sampled at that tick), 5 a second."""
    session = VizSession()
    try:
        session.serve("127.0.0.1", 0)
        session.record(tmp_path / "run.mcap")
        feed = session.telemetry("r")
        _feed, track = _run(session, 10)
        assert feed.published == 5
    finally:
        session.close()
    times = _truth_times(tmp_path / "run.mcap")
    assert times == [round(p.t_s * 1e9) for p in track[1::2]]
