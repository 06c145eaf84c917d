"""Frame capture on a thread: the part every real camera driver shares.

OpenCV's ``VideoCapture.read()`` and picamera2's ``capture_array()`` block until the sensor
delivers the next frame (up to a whole frame period, longer when a USB camera stalls), so they
run on one dedicated worker thread per camera through ``run_in_executor``; the event loop only
sees finished frames. One worker, not the default pool: the capture objects are not
thread-safe, and a stuck read must not starve other executor users.
"""

from __future__ import annotations

import asyncio
import contextlib
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import cv2
import numpy as np
import numpy.typing as npt
import structlog

from hal.devices import DeviceUnavailable
from hal.latest import LatestValue
from hal.readings import Frame
from hal.tasks import cancel_and_wait

log = structlog.get_logger(__name__)

Image = npt.NDArray[Any]  # uint8 BGR (cv2 returns loosely typed arrays)

_MAX_FAILED_READS = 30  # in a row, before the camera counts as gone and is reopened
_REOPEN_MAX_S = 10.0
MIN_FRAME_PX = 16  # the smallest camera.width/height; the tracker needs 8 columns, 2 rows


class CaptureCamera:
    """A `hal.devices.Camera` whose frames come from blocking calls on a worker thread.

    Subclasses implement ``_open``, ``_grab`` (None: no frame this time) and ``_close``; they
    run on the worker thread. ``_pace`` may wait between frames (a video file keeps its rate).
    """

    source = "capture"

    def __init__(self, name: str, width_px: int, height_px: int, fps: float) -> None:
        self.name = name
        self.width_px = width_px
        self.height_px = height_px
        self.fps = fps
        self._frames: LatestValue[Frame] = LatestValue()
        self._executor: ThreadPoolExecutor | None = None
        self._task: asyncio.Task[None] | None = None
        self._seq = 0
        self.failed_reads = 0
        self.reopens = 0
        self.resized = 0
        self.bad_frames = 0
        self.last_error: str | None = None

    def describe(self) -> str:
        return f"camera {self.name}"

    # --- Device -------------------------------------------------------------------------------
    async def start(self) -> None:
        """Open the camera and wait for its first frame; DeviceUnavailable says why not."""
        if self._task is not None:
            return
        self._executor = ThreadPoolExecutor(max_workers=1, thread_name_prefix=self.name)
        try:
            await self._call(self._open)
            grabbed = await self._call(self._grab)
            first = None if grabbed is None else as_bgr(grabbed)
            if first is None:
                what = "no frames" if grabbed is None else (
                    f"unusable frames (shape {grabbed.shape}, dtype {grabbed.dtype})")
                msg = f"{self.describe()}: opened but delivers {what}"
                raise DeviceUnavailable(msg)
        except DeviceUnavailable:
            await self._shutdown()
            raise
        except Exception as exc:  # the capture library's own error (cv2.error, RuntimeError)
            await self._shutdown()
            msg = f"{self.describe()}: cannot read a frame ({type(exc).__name__}: {exc})"
            raise DeviceUnavailable(msg) from exc
        except BaseException:
            await self._shutdown()
            raise
        self.height_px, self.width_px = first.shape[:2]
        self._publish(first)
        log.info("camera.started", camera=self.name, source=self.source,
                 width_px=self.width_px, height_px=self.height_px, fps=self.fps)
        self._task = asyncio.get_running_loop().create_task(self._run(), name=self.name)

    async def close(self) -> None:
        """Stop capturing and release the camera; safe to call twice."""
        task, self._task = self._task, None
        await cancel_and_wait(task)
        await self._shutdown()

    def status(self) -> dict[str, Any]:
        return {"source": self.source, "width_px": self.width_px, "height_px": self.height_px,
                "fps": self.fps, "frames": self._seq, "failed_reads": self.failed_reads,
                "bad_frames": self.bad_frames, "reopens": self.reopens,
                "last_error": self.last_error, "running": self._task is not None}

    # --- Camera -------------------------------------------------------------------------------
    def latest(self) -> Frame | None:
        return self._frames.latest()

    async def next_reading(self) -> Frame:
        return await self._frames.next()

    # --- for subclasses -----------------------------------------------------------------------
    def _open(self) -> None:
        raise NotImplementedError

    def _grab(self) -> Image | None:
        raise NotImplementedError

    def _close(self) -> None:
        raise NotImplementedError

    async def _pace(self) -> None:
        return None

    async def _at_end(self) -> bool:
        """No frame came: True to keep going (e.g. a file rewound), False to give up."""
        return True

    # --- internals ----------------------------------------------------------------------------
    async def _call(self, func: Any) -> Any:
        return await asyncio.get_running_loop().run_in_executor(self._executor, func)

    def _publish(self, image: Image) -> None:
        if image.shape[0] != self.height_px or image.shape[1] != self.width_px:
            self.resized += 1
            image = cv2.resize(image, (self.width_px, self.height_px))
        self._seq += 1
        self._frames.publish(Frame(image, self._seq, asyncio.get_running_loop().time()))

    async def _grab_checked(self) -> Image | None:
        """The next frame, or None when the read failed or the frame cannot be used; a
        capture library's exception counts as a failed read instead of ending the task."""
        try:
            image: Image | None = await self._call(self._grab)
        except Exception as exc:  # cv2.error, picamera2's RuntimeError, OSError
            self.last_error = f"{type(exc).__name__}: {exc}"
            log.warning("camera.read_error", camera=self.name, error=self.last_error)
            return None
        if image is None:
            return None
        frame = as_bgr(image)
        if frame is None:
            self.bad_frames += 1
            self.last_error = f"unusable frame: shape {image.shape}, dtype {image.dtype}"
            log.warning("camera.bad_frame", camera=self.name, shape=list(image.shape),
                        dtype=str(image.dtype))
        return frame

    async def _run(self) -> None:
        misses = 0
        backoff_s = 0.5
        while True:
            await self._pace()
            image = await self._grab_checked()
            if image is not None:
                misses = 0
                backoff_s = 0.5
                self._publish(image)
                continue
            self.failed_reads += 1
            misses += 1
            if not await self._at_end():
                return
            if misses < _MAX_FAILED_READS:
                continue
            log.warning("camera.lost", camera=self.name, failed_reads=misses)
            await self._call(self._close)
            await asyncio.sleep(backoff_s)
            backoff_s = min(_REOPEN_MAX_S, backoff_s * 2)
            try:
                await self._call(self._open)
            except DeviceUnavailable as exc:
                log.warning("camera.reopen_failed", camera=self.name, error=str(exc))
                continue
            self.reopens += 1
            misses = 0
            log.info("camera.reopened", camera=self.name, reopens=self.reopens)

    def _end(self, reason: str) -> None:
        self._frames.fail(DeviceUnavailable(f"{self.describe()}: {reason}"))

    async def _shutdown(self) -> None:
        executor, self._executor = self._executor, None
        if executor is None:
            return
        with contextlib.suppress(Exception):
            await asyncio.get_running_loop().run_in_executor(executor, self._close)
        executor.shutdown(wait=False)



def as_bgr(image: Image) -> Image | None:
    """The frame as 8-bit BGR (h, w, 3), what the line tracker reads; grey and BGRA frames
    are converted. None for what cannot be a frame: empty, tiny, not 8-bit, odd channels."""
    shape: tuple[int, ...] = tuple(getattr(image, "shape", ()))
    if (len(shape) not in (2, 3) or getattr(image, "dtype", None) != np.uint8
            or shape[0] < MIN_FRAME_PX or shape[1] < MIN_FRAME_PX):
        return None
    channels = 1 if len(shape) == 2 else shape[2]
    if channels == 3:
        return image
    if channels == 1:
        return cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
    if channels == 4:
        return cv2.cvtColor(image, cv2.COLOR_BGRA2BGR)
    return None


class OpenCvCapture(CaptureCamera):
    """A source read through ``cv2.VideoCapture`` (a V4L2 device or a video file)."""

    _cap: cv2.VideoCapture | None = None

    def _grab(self) -> Image | None:
        if self._cap is None:
            return None
        ok, image = self._cap.read()
        return image if ok and image is not None else None

    def _close(self) -> None:
        cap, self._cap = self._cap, None
        if cap is not None:
            cap.release()
