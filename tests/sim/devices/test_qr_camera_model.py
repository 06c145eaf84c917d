"""The simulated forward camera draws a held QR code at the size the distance gives."""

from __future__ import annotations

import cv2
import pytest

from sim.devices.qr_camera_model import ForwardMount, SimQrCamera, qr_image
from sim.world.body import DiffDriveBody
from sim.world.floor_plan import World, WorldError
from sim.world.geometry import Pose

PAYLOAD = '{"order_id": 3, "secret_key": "Zz09Zz09"}'


def camera(seed: int = 1) -> SimQrCamera:
    world = World.from_table({"width_m": 6, "height_m": 6,
                              "people": [{"x_m": 3.0, "y_m": 2.0, "qr_payload": PAYLOAD}]})
    return SimQrCamera(world, DiffDriveBody(world, Pose(1.0, 2.0, 0.0)), seed=seed)


def test_the_encoder_code_has_a_quiet_zone() -> None:
    """OpenCV's code plus 4 white modules a side decodes as the payload."""
    image = cv2.resize(qr_image(PAYLOAD), None, fx=6, fy=6, interpolation=cv2.INTER_NEAREST)
    assert cv2.QRCodeDetector().detectAndDecode(image)[0] == PAYLOAD
    assert (image[:24] == 255).all()


def test_the_code_shrinks_with_distance() -> None:
    """Image size falls as the distance grows (pinhole: side x focal / range)."""
    cam = camera()
    sizes = [cam.code_px(d) for d in (0.4, 0.7, 1.0, 2.0)]
    assert sizes == sorted(sizes, reverse=True)
    assert cam.code_px(0.5) == pytest.approx(
        ForwardMount().focal_px * 0.18 / (0.5**2 + 0.5**2) ** 0.5)


def test_close_codes_are_decoded_by_opencv() -> None:
    """At 0.45-0.6 m most frames decode with OpenCV's QRCodeDetector."""
    cam = camera(seed=5)
    detector = cv2.QRCodeDetector()
    decoded = sum(detector.detectAndDecode(cam.render(Pose(3.0 - d, 2.0, 0.03 * i)))[0] == PAYLOAD
                  for d in (0.45, 0.5, 0.55, 0.6) for i in range(-2, 3))
    assert decoded >= 14  # of 20


def test_a_person_who_left_holds_nothing_up() -> None:
    """present = false: the frame is background only."""
    cam = camera()
    cam.world.people[0].present = False
    assert cam.render(Pose(2.5, 2.0, 0.0)).std() < 6


def test_qr_payload_must_be_text() -> None:
    """A number as qr_payload is a world error naming the key."""
    with pytest.raises(WorldError, match=r"people\[0\]\.qr_payload"):
        World.from_table({"width_m": 2, "height_m": 2,
                          "people": [{"x_m": 1.0, "y_m": 1.0, "qr_payload": 5}]})
