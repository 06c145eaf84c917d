"""Samples each simulated robot's path (and the state it was in) for the report."""

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
        # Each sample is a timer callback that sets the next one: one loop turn where a task
        # sleeping in between would cost two.
        loop = asyncio.get_running_loop()
        next_sample = loop.time()
        failed: asyncio.Future[None] = loop.create_future()
        timer: asyncio.TimerHandle | None = None

        def sample() -> None:
            nonlocal next_sample, timer
            try:
                self.sample(loop.time())
            except Exception as exc:  # ends the recorder task with it, as a failing loop would
                failed.set_exception(exc)
                return
            next_sample += self.sample_s
            timer = loop.call_later(max(0.0, next_sample - loop.time()), sample)

        sample()
        try:
            await failed
        finally:
            if timer is not None:
                timer.cancel()

    def sample(self, t_s: float) -> None:
        for name, body in self.bodies.items():
            p = body.pose
            self.tracks.setdefault(name, []).append(
                TrackPoint(t_s, p.x_m, p.y_m, p.heading_rad, self.state_of(name)))
