"""The delivery robot's simulated forward camera and speaker, fitted by the rig."""

from __future__ import annotations

from pathlib import Path

from drivers.camera.qr_reader import QrCameraReader
from hal.backend import Devices
from hal.sim.devices.audio_model import SimAudio
from hal.sim.devices.qr_camera_model import SimQrCamera
from hal.sim.world.body import DiffDriveBody
from hal.sim.world.floor_plan import World
from robotd.config.settings import Settings


def fit_qr_and_audio(devices: Devices, world: World, body: DiffDriveBody, settings: Settings,
                     needs: tuple[str, ...], seed: int) -> None:
    """The forward QR camera (the real decoder on ``SimQrCamera``) and the simulated speaker
    (``audio.dir``'s WAVs, in virtual time) of a robot whose profile uses them."""
    if "qr" in needs:
        devices.qr = QrCameraReader(SimQrCamera(world, body, seed=seed))
    if "audio" in needs:
        devices.audio = SimAudio(Path(str(settings.get("audio.dir"))))
