"""Building real devices from the config: what is needed, and one line per missing device."""

from __future__ import annotations

from pathlib import Path

import pytest

from robotd.config import Settings
from robotd.config.loader import defaults
from robotd.hardware import HardwareMissing, build_devices, needed_slots


def settings(**sections: dict[str, object]) -> Settings:
    values = defaults()
    for name, keys in sections.items():
        values[name].update(keys)
    return Settings(values)


class TestBuildDevices:
    def test_a_profile_that_needs_nothing_gets_no_devices(self) -> None:
        assert build_devices(settings(), ()).distinct() == []

    def test_the_profiles_needs_and_hal_devices_are_merged_in_slot_order(self) -> None:
        s = settings(hal={"devices": ["lidar", "motors"]})
        assert needed_slots(s, ("camera", "motors")) == ["motors", "camera", "lidar"]

    def test_each_missing_device_is_one_line(self) -> None:
        s = settings(hal={"devices": ["encoders", "motors", "toaster"]},
                     serial={"port": "/dev/ttyNOPE3"},
                     camera={"device": "/dev/videoNOPE"})
        with pytest.raises(HardwareMissing) as exc:
            build_devices(s, ("camera",))
        assert exc.value.problems == [
            "hal.devices: unknown device 'toaster' (known: motors, encoders, front_range, "
            "battery, servo, leds, camera, beacons, load_cell, dock_ir, dock_signal, "
            "dock_contacts, bumpers, wall, bin, station, lidar, audio, qr)",
            "motors, encoders (arduino): serial port /dev/ttyNOPE3 does not exist (check "
            "serial.port, the USB cable, and ls /dev/ttyACM* /dev/ttyUSB*)",
            "camera (camera): camera /dev/videoNOPE does not exist (check camera.device and "
            "the cable; ls /dev/video*)",
        ]



class TestFacets:
    def test_the_arduino_link_fills_sensor_slots_with_its_facets(self) -> None:
        """encoders/front_range/battery are the link's feeds, motors the link itself."""
        from drivers.arduino.link import ArduinoLink
        from hal.backend import Devices
        from robotd.hardware import HARDWARE, fill_slots
        from sim.devices.sim_serial import SimSerialPorts

        link = ArduinoLink(SimSerialPorts())
        devices = Devices()
        fill_slots(devices, HARDWARE["arduino"].slots, link)
        assert devices.motors is link and devices.servo is link and devices.leds is link
        assert devices.encoders is link.encoders
        assert devices.front_range is link.front_range
        assert devices.battery is link.battery


class TestQrCamera:
    def test_a_missing_qr_camera_is_one_line(self) -> None:
        """hal.devices = ["qr"] with no such video device: named with what to check."""
        s = settings(hal={"devices": ["qr"]}, qr_camera={"device": "/dev/videoNOPE"})
        with pytest.raises(HardwareMissing) as exc:
            build_devices(s, ())
        assert exc.value.problems == [
            "qr (qr_camera): QR camera /dev/videoNOPE does not exist (check qr_camera.device "
            "and the cable; ls /dev/video*)"]

    def test_a_video_file_gives_a_reader(self, tmp_path: Path) -> None:
        """qr_camera.source = file: the reader wraps the video file camera."""
        from drivers.camera.qr_reader import QrCameraReader

        video = tmp_path / "customer.avi"
        video.write_bytes(b"")
        s = settings(hal={"devices": ["qr"]},
                     qr_camera={"source": "file", "file": str(video)})
        devices = build_devices(s, ())
        assert isinstance(devices.qr, QrCameraReader)
        assert devices.qr.camera.name == "qr_camera"
