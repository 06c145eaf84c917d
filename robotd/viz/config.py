"""The ``[viz]`` section: the Foxglove live view's server and the MCAP recording."""

from __future__ import annotations

from dataclasses import dataclass

from hal.options import Option, Section
from hal.settings import SettingsView

VIZ = Section("viz", "The Foxglove live view (WebSocket) and MCAP recordings (robotd.viz).", (
    Option("enabled", "bool", False,
           "Serve the live view: open Foxglove and connect to ws://HOST:PORT."),
    Option("host", "str", "127.0.0.1",
           "Address the live view listens on (0.0.0.0 exposes it to the whole network)."),
    Option("port", "int", 8765, "The live view's TCP port (0: any free port).",
           min=0, max=65535),
    Option("record", "bool", False,
           "Record the same channels to MCAP files in the state directory (viz/*.mcap)."),
    Option("record_max_bytes", "int", 64_000_000,
           "A recording file is closed and a new one begun past this size.",
           min=100_000, max=100_000_000_000),
    Option("record_files", "int", 5, "Recording files kept; the oldest is deleted.",
           min=1, max=1000),
))
"""The one place the live view's settings and their defaults live."""


@dataclass(frozen=True, slots=True)
class VizConfig:
    enabled: bool
    host: str
    port: int
    record: bool
    record_max_bytes: int
    record_files: int

    @classmethod
    def from_settings(cls, settings: SettingsView) -> VizConfig:
        s = settings.section("viz")
        return cls(bool(s["enabled"]), str(s["host"]), int(s["port"]), bool(s["record"]),
                   int(s["record_max_bytes"]), int(s["record_files"]))
