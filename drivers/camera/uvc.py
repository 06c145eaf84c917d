"""USB (UVC) cameras through OpenCV's V4L2 backend."""

from __future__ import annotations

import os
import re

import cv2

from drivers.camera.capture import OpenCvCapture
from hal.devices import DeviceUnavailable


class UvcCamera(OpenCvCapture):
    """A V4L2 camera, e.g. ``/dev/video0`` (or its index, ``0``).

    Args:
        device: device path or index.
        width_px, height_px, fps: what to ask the camera for; the first frame's size wins.
    """

    source = "uvc"

    def __init__(self, device: str = "/dev/video0", width_px: int = 320, height_px: int = 240,
                 fps: float = 30.0, *, name: str = "camera") -> None:
        super().__init__(name, width_px, height_px, fps)
        self.device = device
        self._cap: cv2.VideoCapture | None = None

    def describe(self) -> str:
        return f"camera {self.device}"

    def _open(self) -> None:
        # OpenCV prints its own WARN lines when a device cannot be opened; the failure is said
        # once, below, with what to check.
        level = cv2.utils.logging.getLogLevel()
        cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_ERROR)
        try:
            cap = cv2.VideoCapture(_v4l2_target(self.device), cv2.CAP_V4L2)
        finally:
            cv2.utils.logging.setLogLevel(level)
        if not cap.isOpened():
            cap.release()
            msg = (f"camera {self.device}: cannot open (plugged in? see `v4l2-ctl "
                   "--list-devices`; is the user in the 'video' group?)")
            raise DeviceUnavailable(msg)
        cap.set(cv2.CAP_PROP_FRAME_WIDTH, self.width_px)
        cap.set(cv2.CAP_PROP_FRAME_HEIGHT, self.height_px)
        cap.set(cv2.CAP_PROP_FPS, self.fps)
        # V4L2 queues several buffers by default; with one, read() returns the newest frame
        # instead of one up to 4 frame periods old.
        cap.set(cv2.CAP_PROP_BUFFERSIZE, 1)
        self._cap = cap


def _v4l2_target(device: str) -> int | str:
    """OpenCV's V4L2 backend opens devices by index: ``0``, ``/dev/video0`` and a
    ``/dev/v4l/by-id/...`` link to it all become 0; anything else is passed as given."""
    if device.isdigit():
        return int(device)
    match = re.fullmatch(r"/dev/video(\d+)", os.path.realpath(device))
    return int(match.group(1)) if match else device
