"""What every simulated camera shares: capturing at its rate on the loop's clock, lazy frames.

A capture takes a snapshot (a "shot": what the camera needs to draw the instant, nothing drawn
yet) at the mount's rate; a frame is rendered from the latest shot only when somebody looks at
it (``latest()``, or a waiter of ``next_reading()`` at the capture), once per shot, so an idle
camera costs little. The subclass says what a shot holds and how it is drawn.
"""

from __future__ import annotations

import asyncio
from typing import Any, Generic, Protocol, TypeVar

import numpy as np
import numpy.typing as npt

from hal.looptime.timer_chain import on_a_grid
from hal.readings import Frame
from hal.tasks import cancel_and_wait


class Shot(Protocol):
    """The least a snapshot holds: its sequence number and capture time."""

    @property
    def seq(self) -> int: ...

    @property
    def t_s(self) -> float: ...


ShotT = TypeVar("ShotT", bound=Shot)


class FrameSource(Generic[ShotT]):
    """A `hal.devices.Camera` whose frames are drawn from shots taken at ``fps``.

    Subclasses set ``name``, ``width_px``, ``height_px`` and implement ``_snapshot`` and
    ``_draw``; ``_status_extra`` adds to ``status()``.
    """

    name: str
    width_px: int
    height_px: int

    def __init__(self, fps: float) -> None:
        self._fps = fps
        self._shot: ShotT | None = None
        self._frame: Frame | None = None
        self._waiters: list[asyncio.Future[Frame]] = []
        self._task: asyncio.Task[None] | None = None
        self.frames_captured = 0
        self.frames_rendered = 0
        self.unplugged = False  # the bench's cable pulled: no frames, reads fail

    # --- Device -------------------------------------------------------------------------------
    async def start(self) -> None:
        if self._task is None:
            self._capture()
            self._task = asyncio.get_running_loop().create_task(self._run(), name=self.name)

    async def close(self) -> None:
        """Stop capturing and release the camera; safe to call twice."""
        task, self._task = self._task, None
        await cancel_and_wait(task)

    def status(self) -> dict[str, Any]:
        return {"source": "sim", "width_px": self.width_px, "height_px": self.height_px,
                "fps": self._fps, "captured": self.frames_captured,
                "rendered": self.frames_rendered, **self._status_extra()}

    # --- Camera -------------------------------------------------------------------------------
    def latest(self) -> Frame | None:
        shot = self._shot
        if shot is None:
            return None
        if self._frame is None or self._frame.seq != shot.seq:
            self._frame = Frame(self._draw(shot), shot.seq, shot.t_s)
            self.frames_rendered += 1
        return self._frame

    async def next_reading(self) -> Frame:
        if self.unplugged:
            msg = f"{self.name}: camera unplugged"
            raise OSError(msg)
        fut: asyncio.Future[Frame] = asyncio.get_running_loop().create_future()
        self._waiters.append(fut)
        return await fut

    def unplug(self) -> None:
        """The camera is gone: reads waiting and to come fail (as a USB camera's do)."""
        self.unplugged = True
        waiters, self._waiters = self._waiters, []
        for fut in waiters:
            if not fut.done():
                fut.set_exception(OSError(f"{self.name}: camera unplugged"))

    def replug(self) -> None:
        self.unplugged = False

    # --- for subclasses -----------------------------------------------------------------------
    def _snapshot(self, seq: int, t_s: float) -> ShotT:
        """What the camera captures now (pose, random draws), to be drawn later if looked at."""
        raise NotImplementedError

    def _draw(self, shot: ShotT) -> npt.NDArray[np.uint8]:
        """The BGR image of ``shot``."""
        raise NotImplementedError

    def _status_extra(self) -> dict[str, Any]:
        return {}

    # --- internals ----------------------------------------------------------------------------
    async def _run(self) -> None:
        # Each capture is a timer callback that sets the next one (hal.looptime.timer_chain):
        # one loop turn a frame, where a task sleeping between frames would cost two.
        await on_a_grid(self._capture, 1.0 / self._fps)

    def _capture(self) -> None:
        if self.unplugged:
            return
        self.frames_captured += 1
        self._shot = self._snapshot(self.frames_captured, asyncio.get_running_loop().time())
        waiters, self._waiters = self._waiters, []
        if waiters:
            frame = self.latest()
            assert frame is not None
            for fut in waiters:
                if not fut.done():
                    fut.set_result(frame)
