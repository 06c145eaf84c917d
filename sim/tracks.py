"""Samples each simulated robot's path (and the state it was in) for the report."""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from dataclasses import dataclass, field

from hal.looptime.timer_chain import timer_chain
from sim.world.body import DiffDriveBody


@dataclass(frozen=True, slots=True)
class TrackPoint:
    t_s: float
    x_m: float
    y_m: float
    heading_rad: float
    state: str


@dataclass
class PathRecorder:
    """Records every body's pose every ``sample_s``; ``state_of(name)`` labels each point.

    Reading a body's pose brings its physics up to the loop's time (bodies integrate lazily),
    so the recorder is also what keeps idle bodies' batteries and timers current.
    """

    bodies: dict[str, DiffDriveBody]
    sample_s: float = 0.1
    state_of: Callable[[str], str] = lambda _name: ""
    tracks: dict[str, list[TrackPoint]] = field(default_factory=dict)

    async def run(self) -> None:
        # Each sample is a timer callback that sets the next one (hal.looptime.timer_chain).
        loop = asyncio.get_running_loop()
        next_sample = loop.time()

        def sample() -> float:
            nonlocal next_sample
            self.sample(loop.time())
            next_sample += self.sample_s
            return max(0.0, next_sample - loop.time())

        await timer_chain(sample)

    def sample(self, t_s: float) -> None:
        for name, body in self.bodies.items():
            p = body.pose
            self.tracks.setdefault(name, []).append(
                TrackPoint(t_s, p.x_m, p.y_m, p.heading_rad, self.state_of(name)))
