"""Steps the simulated bodies at a fixed rate on the event loop's clock, and samples their paths."""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from dataclasses import dataclass, field

from hal.sim.body import DiffDriveBody


@dataclass(frozen=True, slots=True)
class TrackPoint:
    t_s: float
    x_m: float
    y_m: float
    heading_rad: float
    state: str


@dataclass
class Physics:
    """Advances every body by ``dt_s`` per tick and records each body's path every ``sample_s``.

    ``state_of(name)`` tells the path sampler which state the robot was in, so the report can
    colour the path by state.
    """

    bodies: dict[str, DiffDriveBody]
    dt_s: float = 0.01
    sample_s: float = 0.1
    state_of: Callable[[str], str] = lambda _name: ""
    tracks: dict[str, list[TrackPoint]] = field(default_factory=dict)
    steps: int = 0

    async def run(self) -> None:
        loop = asyncio.get_running_loop()
        next_tick = loop.time()
        next_sample = next_tick
        per_sample = max(1, round(self.sample_s / self.dt_s))
        del next_sample
        while True:
            next_tick += self.dt_s
            delay = next_tick - loop.time()
            if delay > 0:
                await asyncio.sleep(delay)
            for body in self.bodies.values():
                body.step(self.dt_s)
            self.steps += 1
            if self.steps % per_sample == 0:
                self.sample(loop.time())

    def sample(self, t_s: float) -> None:
        for name, body in self.bodies.items():
            p = body.pose
            self.tracks.setdefault(name, []).append(
                TrackPoint(t_s, p.x_m, p.y_m, p.heading_rad, self.state_of(name)))
