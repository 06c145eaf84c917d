"""The ``[viz]`` section: the Foxglove live view's server and the MCAP recording."""

from __future__ import annotations

from dataclasses import dataclass

from hal.options import load, section_of, setting
from hal.settings import SettingsView


@dataclass(frozen=True, slots=True)
class VizConfig:
    enabled: bool = setting(False,
                            "Serve the live view: open Foxglove and connect to ws://HOST:PORT.")
    host: str = setting(
        "127.0.0.1",
        "Address the live view listens on (0.0.0.0 exposes it to the whole network).")
    port: int = setting(8765, "The live view's TCP port (0: any free port).", min=0, max=65535)
    record: bool = setting(
        False, "Record the same channels to MCAP files in the state directory (viz/*.mcap).")
    record_max_bytes: int = setting(64_000_000,
                                    "A recording file is closed and a new one begun past this "
                                    "size.", min=100_000, max=100_000_000_000)
    record_files: int = setting(5, "Recording files kept; the oldest is deleted.",
                                min=1, max=1000)

    @classmethod
    def from_settings(cls, settings: SettingsView) -> VizConfig:
        return load(cls, settings.section(VIZ.name))


VIZ = section_of(VizConfig, "viz",
                 "The Foxglove live view (WebSocket) and MCAP recordings (robotd.viz).")
"""The one place the live view's settings and their defaults live."""
