"""The Raspberry Pi camera module through picamera2 (libcamera), imported only when used.

picamera2 is not on PyPI in a usable form for the Pi: it comes from Raspberry Pi OS's
``python3-picamera2`` package. A venv sees it only when created with
``--system-site-packages``; see docs/camera.md for the numpy version trap that comes with it.
"""

from __future__ import annotations

from typing import Any

from drivers.camera.capture import CaptureCamera, Image
from hal.devices import DeviceUnavailable


class PiCamera(CaptureCamera):
    """A CSI camera module (v1-v3, HQ) via picamera2."""

    source = "picamera"

    def __init__(self, width_px: int = 320, height_px: int = 240, fps: float = 30.0, *,
                 index: int = 0, name: str = "camera") -> None:
        super().__init__(name, width_px, height_px, fps)
        self.index = index
        self._cam: Any = None

    def describe(self) -> str:
        return f"Pi camera {self.index}"

    def _open(self) -> None:
        try:
            from picamera2 import Picamera2  # optional: Raspberry Pi OS only
        except ImportError as exc:
            msg = (f"Pi camera {self.index}: picamera2 is not importable ({exc}); install "
                   "python3-picamera2 with apt and make the venv with --system-site-packages "
                   "(docs/camera.md)")
            raise DeviceUnavailable(msg) from exc
        try:
            cam = Picamera2(self.index)
            # "RGB888" in libcamera's naming is B, G, R in memory: OpenCV's BGR order.
            config = cam.create_video_configuration(
                main={"size": (self.width_px, self.height_px), "format": "RGB888"},
                controls={"FrameRate": self.fps}, buffer_count=2)
            cam.configure(config)
            cam.start()
        # picamera2 raises IndexError (no camera), RuntimeError (busy, libcamera), OSError.
        except (IndexError, RuntimeError, OSError, ValueError) as exc:
            msg = (f"Pi camera {self.index}: cannot open ({exc}); check the ribbon cable and "
                   "`rpicam-hello --list-cameras`")
            raise DeviceUnavailable(msg) from exc
        self._cam = cam

    def _grab(self) -> Image | None:
        if self._cam is None:
            return None
        image: Image = self._cam.capture_array("main")
        if image.ndim == 3 and image.shape[2] == 4:
            image = image[:, :, :3]
        return image

    def _close(self) -> None:
        cam, self._cam = self._cam, None
        if cam is not None:
            cam.stop()
            cam.close()
