"""What only the simulator knows, for the live view: the world and each robot's true pose.

The world (its walls as a grid, the painted lines, the beacons and the dock) goes on shared
``/world/...`` topics; each robot's true pose on ``truth`` (a pose in ``map``), beside
the estimate its own localisation publishes. A ``SimFeed`` changes nothing in the run: it has
no timer (the runner calls ``tick`` on its watch ticks: a timer of its own woke the virtual loop
at other instants, and that alone changed the nav run's estimates), and it never touches a body
(a read integrates its physics up to that instant, ``DiffDriveBody.sync``): it takes the poses
the runner's path recorder sampled (``sim.tracks``).

A recording alone (no viewer connected to a server) takes the true poses a second at a time,
each at the instant it was sampled: one call inside a running simulation costs several times
what ten in a row do (the caches are full of the world). A live view gets each as it comes.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Protocol

import structlog

from behaviours.nav.grid import Grid
from robotd.viz.session import VizSession
from robotd.viz.telemetry import FoxgloveTelemetry
from sim.world.floor_plan import World

log = structlog.get_logger(__name__)


class Sample(Protocol):
    """A sampled pose (``sim.tracks.TrackPoint``; not imported: the runner imports us)."""

    @property
    def t_s(self) -> float: ...
    @property
    def x_m(self) -> float: ...
    @property
    def y_m(self) -> float: ...
    @property
    def heading_rad(self) -> float: ...


_TRUTH_EVERY = 2  # the runner's 10 Hz watch ticks: the true pose at 5 Hz
_TRUTH_PERIOD_S = 0.2
_TRUTH_BATCH = 10  # ticks: a recording alone takes the true poses once a second
_SESSION_EVERY = 10  # the session's state for late viewers every second
_WORLD_EVERY = 100  # the world every 10 s, for viewers that join late (a recording's player
# shows the last one before the instant it is at)
_GRID_RESOLUTION_M = 0.05
RECORDING = "run.mcap"
# A simulated camera renders its whole frame only for an image (~0.4 ms, with its JPEG, where
# the tracker's 8 rows cost ~0.1 ms); a real one has the frame anyway. Once the rest of a
# laundry run became ~25 % faster (docs/native.md), 1 Hz images alone kept the recording's
# overhead above the 10 % it may cost: the simulator's camera images are every 2 s.
SIM_PERIODS = {"image": 2.0}


def open_sim_viz(args: argparse.Namespace, name: str, robots: int,
                 say: Callable[[str], None]) -> VizSession | None:
    """The run's session when ``--viz`` serves or ``--report DIR`` records (DIR/run.mcap);
    None otherwise. Raises ``VizError`` (the port is taken...): the run exits 2."""
    report = getattr(args, "report", None)
    serve = bool(getattr(args, "viz", False))
    if not report and not serve:
        return None
    session = VizSession(f"robotd sim {name}", many=robots > 1, periods=SIM_PERIODS)
    try:
        if report:
            session.record(Path(report) / RECORDING)
        if serve:
            host = str(getattr(args, "viz_host", None) or "127.0.0.1")
            port = session.serve(host, int(getattr(args, "viz_port", 8765)))
            say(f"live view: ws://{host}:{port} (Foxglove: Open connection; "
                f"layout viz/robotd-layout.json)")
    except Exception:
        session.close()
        raise
    session.capture_logs()
    return session


class SimFeed:
    """Publishes the world every few seconds and the robots' true poses at 5 Hz (from
    ``tracks``, the path recorder's samples, by robot): as they come when a server is
    serving, else a second at a time; ``flush`` sends what is held at the end of the run."""

    def __init__(self, session: VizSession, world: World,
                 tracks: Mapping[str, Sequence[Sample]]) -> None:
        self.session = session
        self.world = world
        self.tracks = tracks
        self.world_feed = FoxgloveTelemetry(session.context)
        self._ticks = 0
        self._sent: dict[str, int] = {}  # samples looked at, by robot
        self._next_truth_s: dict[str, float] = {}
        self._grid: Grid | None = None
        try:
            self._grid = Grid.from_segments(world.walls.tolist(), _GRID_RESOLUTION_M)
        except ValueError:
            log.info("viz.world_without_walls")

    def tick(self) -> None:
        """Called on each of the runner's watch ticks (10 Hz), after the path recorder's
        sample: no timer of its own, which would wake the virtual loop at other instants."""
        n = self._ticks
        self._ticks += 1
        if self.session.server is not None:
            if n % _TRUTH_EVERY == 0:
                self.flush()
        elif n % _TRUTH_BATCH == _TRUTH_BATCH - 1:
            self.flush()
        if n % _SESSION_EVERY == 0:
            self.session.tick()
        if n % _WORLD_EVERY == 0:
            self.publish_world()

    def flush(self) -> None:
        """The true poses sampled since the last call, at most one per ``_TRUTH_PERIOD_S``
        (the latest when a tick's turn comes), each logged at its sample's time."""
        for name, track in self.tracks.items():
            first = self._sent.get(name, 0)
            self._sent[name] = len(track)
            if first >= len(track):
                continue
            feed = self.session.telemetry(name)
            due_s = self._next_truth_s.get(name, -math.inf)
            live = self.session.server is not None
            for p in (track[-1:] if live else track[first:]):
                # Half a watch tick of slack: sample times are sums of 0.1 s steps.
                if p.t_s >= due_s - _TRUTH_PERIOD_S / 4:
                    due_s = p.t_s + _TRUTH_PERIOD_S
                    feed.pose("truth", (p.x_m, p.y_m, p.heading_rad), t_ns=round(p.t_s * 1e9))
            self._next_truth_s[name] = due_s

    def publish_world(self) -> None:
        """The walls as a grid, the painted lines, the beacons' and the dock's places."""
        feed = self.world_feed
        grid = self._grid
        if grid is not None:
            feed.grid("world/map", grid.occupied, grid.resolution_m,
                      (grid.origin_x_m, grid.origin_y_m))
        for line in self.world.lines:
            points = list(line.points)
            if line.closed and points:
                points.append(points[0])
            feed.path(f"world/line/{line.name}", points)
        nodes = {b.room or b.mac: (b.x_m, b.y_m) for b in self.world.beacons}
        dock = self.world.dock
        if dock is not None:
            nodes["dock"] = (dock.x_m, dock.y_m)
        if nodes:
            feed.graph("world/places", nodes, [])
