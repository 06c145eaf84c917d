"""A recorded video as a camera: replays a run at its own frame rate, on the loop's clock."""

from __future__ import annotations

import asyncio
from pathlib import Path

import cv2
import structlog

from drivers.camera.capture import OpenCvCapture
from hal.devices import DeviceUnavailable

log = structlog.get_logger(__name__)


class VideoFileCamera(OpenCvCapture):
    """Frames from a video file (anything OpenCV's FFmpeg backend decodes).

    Args:
        path: the recording.
        fps: replay rate; None: the rate stored in the file (30 when it has none).
        loop: start again at the end; otherwise waiters get DeviceUnavailable at the end.
    """

    source = "file"

    def __init__(self, path: str | Path, fps: float | None = None, *, loop: bool = False,
                 name: str = "camera") -> None:
        super().__init__(name, 0, 0, fps or 0.0)
        self.path = Path(path)
        self.loop = loop
        self._cap: cv2.VideoCapture | None = None
        self._fixed_fps = fps
        self._next_due: float | None = None
        self.rewinds = 0
        self.ended = False

    def describe(self) -> str:
        return f"camera file {self.path}"

    def _open(self) -> None:
        if not self.path.is_file():
            msg = f"camera file {self.path}: no such file"
            raise DeviceUnavailable(msg)
        cap = cv2.VideoCapture(str(self.path))
        if not cap.isOpened():
            cap.release()
            msg = f"camera file {self.path}: cannot decode it (not a video, or a missing codec)"
            raise DeviceUnavailable(msg)
        stored = cap.get(cv2.CAP_PROP_FPS)
        self.fps = self._fixed_fps or (stored if stored and stored > 0 else 30.0)
        self._cap = cap

    def _rewind(self) -> None:
        if self._cap is not None:
            self._cap.set(cv2.CAP_PROP_POS_FRAMES, 0)

    async def _pace(self) -> None:
        loop = asyncio.get_running_loop()
        now = loop.time()
        due = (self._next_due or now) + 1.0 / self.fps
        self._next_due = max(due, now - 1.0 / self.fps)  # a stall does not cause a burst
        await asyncio.sleep(max(0.0, self._next_due - now))

    async def _at_end(self) -> bool:
        if self.loop:
            self.rewinds += 1
            if self._next_due is not None:
                self._next_due -= 1.0 / self.fps  # the failed read at the end took no slot
            await self._call(self._rewind)
            return True
        self.ended = True
        log.info("camera.file_ended", camera=self.name, path=str(self.path), frames=self._seq)
        self._end(f"end of recording after {self._seq} frames")
        return False
