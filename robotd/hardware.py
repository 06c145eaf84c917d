"""Builds the real devices a robot needs from its config; one clear line per missing device.

Each kind of hardware has a cheap check that runs first (does the serial port exist, is there a
camera, a Bluetooth adapter, a GPIO chip) and a driver factory imported only when needed:
``drivers.<module>.from_settings(settings)`` returns the device object.
"""

from __future__ import annotations

import glob
import importlib
import os
from collections.abc import Callable, Iterable
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

from hal.backend import Devices
from robotd.config.settings import Settings

Check = Callable[[Settings], str | None]


class HardwareMissing(Exception):
    """Devices the robot needs are not there; ``problems`` holds one line per device."""

    def __init__(self, problems: list[str]) -> None:
        self.problems = problems
        super().__init__("\n".join(problems))


@dataclass(frozen=True, slots=True)
class Hardware:
    """One piece of hardware: the ``Devices`` slots it fills, a check, its driver factory."""

    slots: tuple[str, ...]
    check: Check
    factory: str
    """``module:function`` called with the settings."""


def _serial_check(settings: Settings) -> str | None:
    port = str(settings.get("serial.port"))
    if not Path(port).exists():
        return (f"serial port {port} does not exist (check serial.port, the USB cable, and "
                "ls /dev/ttyACM* /dev/ttyUSB*)")
    if not os.access(port, os.R_OK | os.W_OK):
        return f"no permission to open {port} (is the user in the dialout group?)"
    return None


def _lidar_check(settings: Settings) -> str | None:
    port = str(settings.get("lidar.port"))
    if not Path(port).exists():
        return (f"LiDAR port {port} does not exist (check lidar.port, the USB cable, and "
                "ls /dev/ttyUSB*)")
    if not os.access(port, os.R_OK):
        return f"no permission to open {port} (is the user in the dialout group?)"
    return None


def _camera_check(settings: Settings) -> str | None:
    if settings.get("camera.source") != "uvc":
        return None
    device = str(settings.get("camera.device"))
    if not Path(device).exists():
        return f"camera {device} does not exist (check camera.device and the cable; ls /dev/video*)"
    return None


def _qr_camera_check(settings: Settings) -> str | None:
    if settings.get("qr_camera.source") != "uvc":
        return None
    device = str(settings.get("qr_camera.device"))
    if not Path(device).exists():
        return (f"QR camera {device} does not exist (check qr_camera.device and the cable; "
                "ls /dev/video*)")
    return None


def _dock_ir_check(settings: Settings) -> str | None:
    if settings.get("docking.ir_source") != "stream":
        return _any_path("/dev/gpiochip*", "GPIO chip")(settings)
    stream = str(settings.get("docking.ir_stream"))
    if not Path(stream).exists():
        return f"IR edge pipe {stream} does not exist (check docking.ir_stream; mkfifo it)"
    return None


def _ble_check(settings: Settings) -> str | None:
    if settings.get("ble.source") != "stream":
        return _any_path("/sys/class/bluetooth/hci*", "Bluetooth adapter")(settings)
    stream = str(settings.get("ble.stream"))
    if not Path(stream).exists():
        return f"advert pipe {stream} does not exist (check ble.stream; mkfifo it)"
    return None


def _hx711_check(settings: Settings) -> str | None:
    if settings.get("hx711.source") != "stream":
        return _any_path("/dev/gpiochip*", "GPIO chip")(settings)
    stream = str(settings.get("hx711.stream"))
    if not Path(stream).exists():
        return f"conversion pipe {stream} does not exist (check hx711.stream; mkfifo it)"
    return None


def _audio_check(settings: Settings) -> str | None:
    # ALSA's null device plays into nothing: a robot without a speaker, or a bench.
    if settings.get("audio.device") == "null":
        return None
    return _any_path("/dev/snd/pcm*", "sound card")(settings)


def _any_path(pattern: str, what: str) -> Check:
    def check(_settings: Settings) -> str | None:
        return None if glob.glob(pattern) else f"no {what} found ({pattern})"
    return check


HARDWARE: dict[str, Hardware] = {
    "arduino": Hardware(("motors", "encoders", "front_range", "battery", "servo", "leds",
                         "dock_signal", "dock_contacts", "bumpers", "wall", "bin", "station"),
                        _serial_check, "drivers.arduino:from_settings"),
    "camera": Hardware(("camera",), _camera_check, "drivers.camera:from_settings"),
    "ble": Hardware(("beacons",), _ble_check,
                    "drivers.ble_scanner:from_settings"),
    "hx711": Hardware(("load_cell",), _hx711_check,
                      "drivers.hx711:from_settings"),
    "dock_ir": Hardware(("dock_ir",), _dock_ir_check,
                        "drivers.dock_ir:from_settings"),
    "lidar": Hardware(("lidar",), _lidar_check, "drivers.lidar:from_settings"),
    "audio": Hardware(("audio",), _audio_check,
                      "drivers.audio:from_settings"),
    "qr_camera": Hardware(("qr",), _qr_camera_check, "drivers.camera.qr_reader:from_settings"),
}
SLOTS = tuple(f.name for f in fields(Devices)
              if any(f.name in hw.slots for hw in HARDWARE.values()))
"""The device slots real hardware fills (``network`` is the operating system's)."""


def needed_slots(settings: Settings, profile_devices: Iterable[str]) -> list[str]:
    """The profile's device slots plus ``hal.devices``, in slot order, each once."""
    wanted = set(profile_devices) | set(settings.get("hal.devices"))
    return [s for s in SLOTS if s in wanted] + sorted(wanted - set(SLOTS))


def build_devices(settings: Settings, profile_devices: Iterable[str]) -> Devices:
    """Check and construct (not open) each needed device; HardwareMissing lists what lacks."""
    devices = Devices()
    problems: list[str] = []
    wanted: dict[str, list[str]] = {}
    for slot in needed_slots(settings, profile_devices):
        name = next((n for n, hw in HARDWARE.items() if slot in hw.slots), None)
        if name is None:
            problems.append(f"hal.devices: unknown device {slot!r} (known: {', '.join(SLOTS)})")
        else:
            wanted.setdefault(name, []).append(slot)
    for name, slots in wanted.items():
        device = _construct(HARDWARE[name], settings)
        if isinstance(device, str):
            problems.append(f"{', '.join(slots)} ({name}): {device}")
            continue
        fill_slots(devices, HARDWARE[name].slots, device)
    if problems:
        raise HardwareMissing(problems)
    return devices


def _construct(hardware: Hardware, settings: Settings) -> Any:
    """The device, or a string saying why it cannot be had."""
    why = hardware.check(settings)
    if why is not None:
        return why
    module_name, _, function = hardware.factory.partition(":")
    try:
        factory = getattr(importlib.import_module(module_name), function)
    except (ImportError, AttributeError):
        return f"this installation has no driver for it ({hardware.factory} is missing)"
    try:
        return factory(settings)
    except Exception as exc:  # a driver refusing its settings: say so on one line
        return f"the driver refused its settings: {exc}"


def fill_slots(devices: Devices, slots: tuple[str, ...], device: Any) -> None:
    """Put ``device`` in its slots; a driver that fills several offers each as a facet of the
    same name (the Arduino link's ``.encoders``, ``.front_range``, ``.battery``)."""
    for slot in slots:
        facet = FACETS.get(slot)
        if facet is not None and hasattr(device, facet[0]):
            setattr(devices, slot, getattr(getattr(device, facet[0]), facet[1]))
        else:
            setattr(devices, slot, getattr(device, slot, device))


FACETS = {"dock_signal": ("dock", "signal"), "dock_contacts": ("dock", "contacts"),
          "bumpers": ("dock", "bumpers"), "wall": ("dock", "wall"), "bin": ("dock", "bin")}
"""Slots a driver offers one level down: the Arduino link's docking lines (``link.dock``)."""
