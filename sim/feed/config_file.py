"""The ``robotd.toml`` a real daemon runs the simulated robot with: the scenario's settings,
the hardware keys pointed at the feeder's ports, files, socket and state directory."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from robotd.config.loader import defaults
from robotd.config.overrides import render_toml
from robotd.config.settings import Settings


def hardware_keys(work: Path, *, mcu_port: Path, lidar_port: Path | None) -> dict[str, Any]:
    """The keys that send the serial drivers, the socket, the state and the speaker to the
    feeder's (dotted key -> value)."""
    keys: dict[str, Any] = {
        "hal.backend": "real", "control.socket": str(work / "control.sock"),
        "robot.state_dir": str(work / "state"), "serial.port": str(mcu_port),
        "audio.device": "null",  # the robot speaks into ALSA's null device: no sound card
    }
    if lidar_port is not None:
        keys["lidar.port"] = str(lidar_port)
    return keys


def write_config(path: Path, settings: Settings, keys: dict[str, Any]) -> None:
    """Every key the scenario (and the rig) set away from its default, then ``keys``."""
    values = settings.as_dict()
    for dotted, value in keys.items():
        section, _, key = dotted.partition(".")
        values[section][key] = value
    base = defaults()
    changed = {section: {k: v for k, v in table.items() if base[section].get(k) != v}
               for section, table in values.items()}
    body = render_toml({s: t for s, t in changed.items() if t}).split("\n", 1)[1]
    path.write_text("# Written by python -m sim.feed for robotd run: a simulated robot's hardware "
                    "on ptys, pipes and files.\n" + body)
