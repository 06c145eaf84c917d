"""Camera drivers: USB/UVC (V4L2), the Pi camera module (picamera2), recorded video files."""

from __future__ import annotations

import asyncio
from collections.abc import Mapping
from typing import Any

from drivers.camera.capture import CaptureCamera
from drivers.camera.picamera import PiCamera
from drivers.camera.uvc import UvcCamera
from drivers.camera.video_file import VideoFileCamera
from hal.devices import DeviceUnavailable
from hal.settings import SettingsView

__all__ = ["CaptureCamera", "PiCamera", "UvcCamera", "VideoFileCamera", "from_settings",
           "open_camera", "probe"]

_KEYS = ("source", "device", "file", "loop", "width", "height", "fps")


def from_settings(settings: SettingsView) -> CaptureCamera:
    """The camera from the ``camera`` section (``robotd.hardware`` calls this)."""
    return open_camera({key: settings.get(f"camera.{key}") for key in _KEYS})


def open_camera(options: Mapping[str, Any], *, name: str = "camera") -> CaptureCamera:
    """Build (not start) the camera the ``camera`` config section describes."""
    source = options.get("source", "uvc")
    width, height, fps = options.get("width", 320), options.get("height", 240), options.get(
        "fps", 30.0)
    if source == "uvc":
        return UvcCamera(str(options.get("device", "/dev/video0")), width, height, fps,
                         name=name)
    if source == "picamera":
        return PiCamera(width, height, fps, name=name)
    if source == "file":
        path = str(options.get("file", ""))
        if not path:
            msg = "camera.file: empty, but camera.source = 'file' needs a video file"
            raise DeviceUnavailable(msg)
        return VideoFileCamera(path, fps, loop=bool(options.get("loop", False)), name=name)
    msg = f"camera.source: unknown source {source!r} (uvc, picamera, file)"
    raise DeviceUnavailable(msg)


async def probe(camera: CaptureCamera, frames: int = 30, timeout_s: float = 5.0
                ) -> dict[str, Any]:
    """A technician's check: open, read ``frames`` frames, report size, rate and brightness."""
    loop = asyncio.get_running_loop()
    await camera.start()
    try:
        first = camera.latest()
        t0 = loop.time()
        got = 0
        last = first
        async with asyncio.timeout(timeout_s):
            while got < frames:
                last = await camera.next_reading()
                got += 1
        elapsed = loop.time() - t0
    except TimeoutError:
        elapsed = loop.time() - t0
    finally:
        await camera.close()
    brightness = None if last is None else round(float(last.image.mean()), 1)
    return {"source": camera.source, "width_px": camera.width_px,
            "height_px": camera.height_px, "frames": got,
            "fps_measured": round(got / elapsed, 2) if elapsed > 0 else None,
            "mean_brightness": brightness, **{k: v for k, v in camera.status().items()
                                               if k in ("failed_reads", "reopens")}}
