"""QR codes from a forward camera, decoded with OpenCV's ``QRCodeDetector`` (no zbar).

Decoding a 640 x 480 frame takes tens of milliseconds, so it runs on one worker thread of its
own: OpenCV releases the GIL inside ``detectAndDecodeBytes``, so the event loop (and the control
loop on it) keeps running while a frame is decoded. One worker, not the default pool: a detector
is not thread-safe, and decoding must not starve other executor users (the orders database).
Frames are decoded only while someone waits for a code, and only the newest one: frames that
arrive during a decode are skipped, never queued.
"""

from __future__ import annotations

import asyncio
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import cv2
import numpy.typing as npt
import structlog

from drivers.camera import open_camera
from hal.devices import Camera
from hal.settings import SettingsView

log = structlog.get_logger(__name__)

Image = npt.NDArray[Any]  # uint8 BGR or grey
_CAMERA_RETRY_S = 0.5  # after a failed frame read, before asking again
_KEYS = ("source", "device", "file", "loop", "width", "height", "fps")


def from_settings(settings: SettingsView) -> QrCameraReader:
    """The reader on the camera the ``qr_camera`` section describes (``robotd.hardware``)."""
    camera = open_camera({key: settings.get(f"qr_camera.{key}") for key in _KEYS},
                         name="qr_camera")
    return QrCameraReader(camera)


class QrCameraReader:
    """A `hal.devices.QrReader` over any `hal.devices.Camera` (real, a file, or simulated).

    Args:
        camera: the forward camera; started and closed with the reader.
        name: the device's name in ``robotctl sensors``.
    """

    def __init__(self, camera: Camera, *, name: str = "qr") -> None:
        self.name = name
        self.camera = camera
        self._detector = cv2.QRCodeDetector()
        self._executor: ThreadPoolExecutor | None = None
        self._lock = asyncio.Lock()
        self.frames_decoded = 0
        self.codes_found = 0
        self.camera_errors = 0
        self.last_decode_s = 0.0
        self.last_error: str | None = None
        self.camera_failing = False  # the last frame read failed (unplugged, broken)

    async def start(self) -> None:
        if self._executor is None:
            self._executor = ThreadPoolExecutor(1, thread_name_prefix=f"{self.name}-decode")
        await self.camera.start()

    async def close(self) -> None:
        """Close the camera and the worker; safe to call twice."""
        await self.camera.close()
        executor, self._executor = self._executor, None
        if executor is not None:
            # A decode in flight ends by itself within one frame's work; do not wait for it.
            executor.shutdown(wait=False, cancel_futures=True)

    def status(self) -> dict[str, Any]:
        return {"frames_decoded": self.frames_decoded, "codes_found": self.codes_found,
                "camera_errors": self.camera_errors,
                "camera_failing": self.camera_failing,
                "last_decode_ms": round(self.last_decode_s * 1000, 1),
                "last_error": self.last_error, "camera": self.camera.status()}

    async def next_code(self, timeout_s: float) -> bytes | None:
        """The payload of the next code seen within ``timeout_s``, else None."""
        try:
            async with asyncio.timeout(timeout_s), self._lock:
                while True:
                    payload = await self._one_frame()
                    if payload:
                        self.codes_found += 1
                        log.info("qr.code", bytes=len(payload))
                        return payload
        except TimeoutError:
            return None

    async def decode(self, image: Image) -> bytes:
        """Decode one image on the worker thread (b"" when it holds no readable code)."""
        loop = asyncio.get_running_loop()
        executor = self._executor
        if executor is None:
            executor = self._executor = ThreadPoolExecutor(
                1, thread_name_prefix=f"{self.name}-decode")
        t0 = loop.time()
        payload = await loop.run_in_executor(executor, self._decode_blocking, image)
        self.last_decode_s = loop.time() - t0
        self.frames_decoded += 1
        return payload

    async def _one_frame(self) -> bytes:
        try:
            frame = await self.camera.next_reading()
        except Exception as exc:  # a camera's failure is the camera's; QR just waits it out
            self.camera_errors += 1
            self.camera_failing = True
            self.last_error = f"{type(exc).__name__}: {exc}"
            log.warning("qr.camera_error", error=self.last_error)
            await asyncio.sleep(_CAMERA_RETRY_S)
            return b""
        self.camera_failing = False
        return await self.decode(frame.image)

    def _decode_blocking(self, image: Image) -> bytes:
        # Runs on the worker thread. OpenCV raises cv2.error on odd images; that is "no code".
        try:
            payload, points, _ = self._detector.detectAndDecodeBytes(image)
        except cv2.error as exc:
            self.last_error = f"cv2.error: {str(exc)[:120]}"
            return b""
        return bytes(payload) if points is not None and payload else b""

