"""The QR reader: OpenCV's decoder on a forward camera's frames, off the event loop."""

from __future__ import annotations

import asyncio
from typing import Any

import numpy as np
import pytest

from drivers.camera.qr_reader import QrCameraReader
from hal.devices import QrReader
from hal.readings import Frame
from sim import vclock
from sim.devices.qr_camera_model import SimQrCamera
from sim.world.body import DiffDriveBody
from sim.world.floor_plan import Person, World
from sim.world.geometry import Pose

PAYLOAD = '{"order_id": 12, "secret_key": "abcdefgh12345678"}'


def customer_world(distance_m: float, payload: str | None = PAYLOAD) -> tuple[World, DiffDriveBody]:
    world = World.from_table({"width_m": 6, "height_m": 6})
    world.people.append(Person("customer", 3.0, 2.0, qr_payload=payload))
    return world, DiffDriveBody(world, Pose(3.0 - distance_m, 2.0, 0.0))


def read_code(distance_m: float, payload: str | None = PAYLOAD, timeout_s: float = 3.0
              ) -> tuple[bytes | None, QrCameraReader]:
    world, body = customer_world(distance_m, payload)
    reader = QrCameraReader(SimQrCamera(world, body, seed=2))

    async def main() -> bytes | None:
        await reader.start()
        try:
            return await reader.next_code(timeout_s)
        finally:
            await reader.close()

    code: bytes | None = vclock.run(main())
    return code, reader


def test_reads_the_customers_code_at_half_a_metre() -> None:
    """A customer 0.5 m ahead holding an order's code: its payload bytes come back."""
    code, reader = read_code(0.5)
    assert code == PAYLOAD.encode()
    assert isinstance(reader, QrReader)
    assert reader.codes_found == 1


def test_nobody_holding_a_code_times_out_with_none() -> None:
    """No code in view: None after the timeout, every frame tried."""
    code, reader = read_code(0.5, payload=None, timeout_s=1.0)
    assert code is None
    assert 5 <= reader.frames_decoded <= 11  # 10 frames a second


def test_a_code_behind_the_robot_is_not_seen() -> None:
    """A customer behind the camera is not in the image."""
    world, body = customer_world(0.5)
    camera = SimQrCamera(world, body)
    ahead = camera.render(Pose(2.5, 2.0, 0.0))
    behind = camera.render(Pose(2.5, 2.0, np.pi))
    assert ahead.std() > behind.std() * 2


class FailingCamera:
    """A camera whose every read fails (unplugged): the reader must wait it out."""

    name = "broken"
    width_px = 640
    height_px = 480

    async def start(self) -> None:
        return None

    async def close(self) -> None:
        return None

    def status(self) -> dict[str, Any]:
        return {}

    def latest(self) -> Frame | None:
        return None

    async def next_reading(self) -> Frame:
        await asyncio.sleep(0.01)
        msg = "camera unplugged"
        raise OSError(msg)


def test_a_failing_camera_is_counted_never_raised() -> None:
    """Camera errors are counted and named in status; next_code returns None."""
    reader = QrCameraReader(FailingCamera())

    async def main() -> bytes | None:
        await reader.start()
        try:
            return await reader.next_code(2.0)
        finally:
            await reader.close()

    assert vclock.run(main()) is None
    assert reader.camera_errors >= 3
    assert "camera unplugged" in str(reader.status()["last_error"])


@pytest.mark.parametrize("image", [np.zeros((1, 1, 3), np.uint8), np.zeros((480, 640), np.uint8)])
async def test_odd_images_decode_to_nothing(image: np.ndarray[Any, Any]) -> None:
    """Tiny or grey images are not codes; nothing raises."""
    reader = QrCameraReader(FailingCamera())
    try:
        assert await reader.decode(image) == b""
    finally:
        await reader.close()
