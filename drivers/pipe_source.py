"""Opening the named pipe a ``source = "stream"`` device reads its lines from (dock IR edges,
BLE adverts, HX711 conversions): one check and one way to open it for all three."""

from __future__ import annotations

import os
import stat
from pathlib import Path

from hal.devices import DeviceUnavailable


def open_line_pipe(path: Path, device: str, key: str, *, char_device: bool = False) -> int:
    """The pipe's descriptor, opened read-write (a writer that leaves is no end of file) and
    non-blocking; DeviceUnavailable naming the device and its config key when ``path`` is
    missing or no named pipe (``char_device``: a character device will do too)."""
    try:
        mode = path.stat().st_mode
    except OSError as exc:
        msg = f"{device}: cannot open {path} ({exc}); check {key}"
        raise DeviceUnavailable(msg) from exc
    if not (stat.S_ISFIFO(mode) or (char_device and stat.S_ISCHR(mode))):
        msg = f"{device}: {path} is not a named pipe (make it with mkfifo); check {key}"
        raise DeviceUnavailable(msg)
    return os.open(path, os.O_RDWR | os.O_NONBLOCK)
