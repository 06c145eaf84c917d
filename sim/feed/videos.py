"""Video files the real camera drivers read (``source = "file"``), made once from the world."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import numpy.typing as npt

from sim.devices.qr_camera_model import qr_image
from sim.world.floor_plan import World

CODE_SIDE_FRACTION = 0.5  # the card fills half the frame's height: held up to the camera


def first_qr_payload(world: World) -> str | None:
    """The code the first person who carries one would show."""
    return next((p.qr_payload for p in world.people if p.qr_payload), None)


def write_qr_video(path: Path, payload: str, *, width_px: int, height_px: int, fps: float,
                   seconds: float = 2.0) -> Path:
    """A customer holding ``payload``'s code still in front of the camera (MJPEG in AVI: what
    OpenCV writes and reads back everywhere), ``seconds`` long at ``fps``."""
    code = qr_image(payload)
    side = int(height_px * CODE_SIDE_FRACTION)
    card = cv2.resize(code, (side, side), interpolation=cv2.INTER_NEAREST)
    frame = np.full((height_px, width_px, 3), 170, np.uint8)  # a grey shop behind the card
    top, left = (height_px - side) // 2, (width_px - side) // 2
    frame[top:top + side, left:left + side] = card[:, :, None]
    return write_still_video(path, frame, fps=fps, seconds=seconds)


def write_still_video(path: Path, frame: npt.NDArray[np.uint8], *, fps: float,
                      seconds: float = 2.0) -> Path:
    """``frame`` held still for ``seconds`` at ``fps`` (MJPEG in AVI)."""
    height_px, width_px = frame.shape[:2]
    if frame.ndim == 2:
        frame = np.asarray(cv2.cvtColor(frame, cv2.COLOR_GRAY2BGR), np.uint8)
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter.fourcc(*"MJPG"), fps,
                             (width_px, height_px))
    if not writer.isOpened():
        msg = f"cannot write {path} (OpenCV has no MJPEG writer)"
        raise RuntimeError(msg)
    try:
        for _ in range(max(1, round(seconds * fps))):
            writer.write(frame)
    finally:
        writer.release()
    return path
