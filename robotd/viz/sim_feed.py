"""What only the simulator knows, for the live view: the world and each robot's true pose.

The world (its walls as a grid, the painted lines, the beacons and the dock) goes on shared
``/world/...`` topics; each robot's true pose on ``truth`` (a pose in ``map``), beside
the estimate its own localisation publishes. A ``SimFeed`` only reads the world and the bodies:
it never changes what the robots do (events.jsonl is the same with and without it).
"""

from __future__ import annotations

import argparse
import asyncio
from collections.abc import Callable, Mapping
from pathlib import Path

import structlog

from behaviours.nav.grid import Grid
from hal.sim.world.body import DiffDriveBody
from hal.sim.world.floor_plan import World
from robotd.viz.session import VizSession
from robotd.viz.telemetry import FoxgloveTelemetry

log = structlog.get_logger(__name__)

TRUTH_PERIOD_S = 0.2
_WORLD_EVERY = 25  # truth ticks: the world every 5 s, for viewers that join late
_GRID_RESOLUTION_M = 0.05
RECORDING = "run.mcap"


def open_sim_viz(args: argparse.Namespace, name: str, robots: int,
                 say: Callable[[str], None]) -> VizSession | None:
    """The run's session when ``--viz`` serves or ``--report DIR`` records (DIR/run.mcap);
    None otherwise. Raises ``VizError`` (the port is taken...): the run exits 2."""
    report = getattr(args, "report", None)
    serve = bool(getattr(args, "viz", False))
    if not report and not serve:
        return None
    session = VizSession(f"robotd sim {name}", many=robots > 1)
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
    """Publishes the world every few seconds and the bodies' true poses at 5 Hz."""

    def __init__(self, session: VizSession, world: World,
                 bodies: Mapping[str, DiffDriveBody]) -> None:
        self.session = session
        self.world = world
        self.bodies = bodies
        self.world_feed = FoxgloveTelemetry(session.context)
        self._ticks = 0
        self._grid: Grid | None = None
        try:
            self._grid = Grid.from_segments(world.walls.tolist(), _GRID_RESOLUTION_M)
        except ValueError:
            log.info("viz.world_without_walls")

    async def run(self) -> None:
        while True:
            self.tick()
            await asyncio.sleep(TRUTH_PERIOD_S)

    def tick(self) -> None:
        for name, body in self.bodies.items():
            p = body.pose
            self.session.telemetry(name).pose("truth", (p.x_m, p.y_m, p.heading_rad))
        if self._ticks % _WORLD_EVERY == 0:
            self.publish_world()
        self._ticks += 1

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
