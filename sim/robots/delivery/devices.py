"""The delivery robot's simulated forward camera and speaker, fitted by the rig."""

from __future__ import annotations

from pathlib import Path

from drivers.camera.qr_reader import QrCameraReader
from hal.backend import Devices
from robotd.config.settings import Settings
from sim.devices.audio_model import SimAudio
from sim.devices.qr_camera_model import SimQrCamera
from sim.world.body import DiffDriveBody
from sim.world.floor_plan import World


def fit_qr_and_audio(devices: Devices, world: World, body: DiffDriveBody, settings: Settings,
                     needs: tuple[str, ...], seed: int) -> None:
    """The forward QR camera (the real decoder on ``SimQrCamera``) and the simulated speaker
    (``audio.dir``'s WAVs, in virtual time) of a robot whose profile uses them."""
    if "qr" in needs:
        devices.qr = QrCameraReader(SimQrCamera(world, body, seed=seed))
    if "audio" in needs:
        devices.audio = SimAudio(Path(str(settings.get("audio.dir"))))
