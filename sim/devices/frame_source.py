"""What every simulated camera shares: capturing at its rate on the loop's clock, lazy frames.

A capture takes a snapshot (a "shot": what the camera needs to draw the instant, nothing drawn
yet) at the mount's rate; a frame is rendered from the latest shot only when somebody looks at
it (``latest()``, or a waiter of ``next_reading()`` at the capture), once per shot, so an idle
camera costs little. Even then a frame draws only what is read of it: the rows asked for
(``Frame.rows``, the line tracker's scan rows) where the subclass can draw rows alone, the
whole image (once) when ``Frame.image`` is read. The subclass says what a shot holds and how it
is drawn.
"""

from __future__ import annotations

import asyncio
from collections.abc import Sequence
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
    ``_draw``; ``_draw_rows`` draws some rows alone (by default they are cut from ``_draw``'s
    image); ``_status_extra`` adds to ``status()``.
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
            self._frame = Frame.painted(_ShotPainter(self, shot), shot.seq, shot.t_s)
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

    def _draw_rows(self, shot: ShotT, rows: Sequence[int]) -> npt.NDArray[np.uint8] | None:
        """Rows ``rows`` of ``_draw(shot)``, the same bytes, drawn alone (None: not drawn
        alone, they are cut from the whole image)."""
        return None

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


class _ShotPainter(Generic[ShotT]):
    """Draws one shot of ``source`` for its Frame: rows alone, or the whole image once."""

    __slots__ = ("_counted", "_image", "_shot", "_source")

    def __init__(self, source: FrameSource[ShotT], shot: ShotT) -> None:
        self._source = source
        self._shot = shot
        self._image: npt.NDArray[np.uint8] | None = None
        self._counted = False

    @property
    def shape(self) -> tuple[int, int, int]:
        return self._source.height_px, self._source.width_px, 3

    def image(self) -> npt.NDArray[np.uint8]:
        if self._image is None:
            self._count()
            self._image = self._source._draw(self._shot)
        return self._image

    def rows(self, indices: Sequence[int]) -> npt.NDArray[np.uint8]:
        if self._image is None:
            self._count()
            rows = self._source._draw_rows(self._shot, indices)
            if rows is not None:
                return rows
        picked: npt.NDArray[np.uint8] = self.image()[np.asarray(indices, np.intp)]
        return picked

    def _count(self) -> None:
        if not self._counted:  # a frame is counted once, however much of it is drawn
            self._source.frames_rendered += 1
            self._counted = True
