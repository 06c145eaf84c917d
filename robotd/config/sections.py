"""Every configuration section and key robotd knows (unknown keys are errors).

The daemon's own sections are here; a driver or a capability declares its section beside its
code, as the fields of the dataclass it reads (``hal.options.section_of``; ``serial``:
``drivers/arduino/config.py``, ``line_follow``: ``behaviours/line/config.py``), and a robot
profile its own (``behaviours/profiles/<name>/``), which the profile registry
(``robotd/profiles.py``) brings in. The contract keys of DESIGN.md keep their names.
``SECTIONS`` and ``ORDERS`` always reflect the registry as it is.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from typing import overload

from behaviours.docking.config import DOCKING_OPTIONS, DOCKING_ORDERS
from behaviours.line.config import LINE_FOLLOW, LINE_FOLLOW_ORDERS
from behaviours.motion.config import DRIVE, DRIVE_ORDERS
from behaviours.nav.config import NAV_SECTIONS
from behaviours.nav.localisation.config import NAV_LOCALISATION_ORDERS, NAV_LOCALISATION_SECTIONS
from drivers.arduino.config import SERIAL
from drivers.audio.config import AUDIO
from drivers.camera.qr_config import QR_CAMERA
from drivers.dock_ir.config import IR_OPTIONS, IR_ORDERS
from drivers.hx711_config import HX711
from drivers.lidar.config import LIDAR, LIDAR_ORDERS
from hal.options import Option, Order, Section
from robotd.profiles import DEFAULT_PROFILE, PROFILES, ProfileRegistry
from robotd.viz.config import VIZ

opt = Option


def _robot_section(profiles: list[str]) -> Section:
    return Section("robot", "Who this robot is.", (
        opt("name", "str", "robot-1", "Robot name, as the fleet server knows it.", min=1),
        opt("profile", "str", DEFAULT_PROFILE, "Which robot this is.", choices=tuple(profiles),
            unknown="unknown profile"),
        opt("state_dir", "str", "/var/lib/robotd",
            "Where mission state and tuning overrides are kept ($STATE_DIRECTORY wins)."),
    ))


_CORE: tuple[Section, ...] = (
    Section("hal", "Hardware backend.", (
        opt("backend", "str", "real", "real: the drivers; sim: the simulated world.",
          choices=("real", "sim")),
        opt("devices", "list[str]", [],
          "Devices to open besides those the profile needs: motors (the Arduino board), "
          "camera, beacons, load_cell, dock_ir, lidar, audio, qr (the forward QR camera)."),
    )),
    Section("control", "The local control socket for robotctl.", (
        opt("socket", "str", "/run/robotd/control.sock", "Unix socket path."),
        opt("max_clients", "int", 64, "Connections accepted at once.", min=1, max=4096),
        opt("client_queue", "int", 256,
          "Lines queued per client: past it a subscriber loses notifications, and a client "
          "is not read until its replies drain.", min=1, max=100000),
        opt("idle_timeout_s", "float", 60.0,
          "A connection that sends no request for this long is closed (not a reading "
          "subscriber).", min=0.1, max=86400),
        opt("stall_timeout_s", "float", 10.0,
          "A connection whose replies have not drained for this long is closed.",
          min=0.1, max=3600),
        opt("evict_idle_s", "float", 1.0,
          "When the socket is full, a connection idle or stalled this long gives its place "
          "to a newcomer.", min=0.0, max=3600),
        opt("wait_max", "int", 128, "Connections past max_clients that wait for a place.",
          min=0, max=4096),
        opt("wait_s", "float", 1.0, "How long a waiting connection may wait for a place.",
          min=0.01, max=60),
        opt("lines_per_s", "float", 4096.0,
          "Work units a client may spend per second (a request is one, 256 blank lines one).",
          min=1, max=1e7),
        opt("lines_burst", "float", 4096.0, "Work units a client may spend at once.",
          min=1, max=1e7),
    )),
    Section("logging", "Structured logs.", (
        opt("level", "str", "info", "Lowest level logged.",
          choices=("debug", "info", "warning", "error"), tunable=True),
    )),
    Section("supervisor", "Service start, restart and stop.", (
        opt("stop_timeout_s", "float", 3.0, "Time each service gets to stop.", min=0.1, max=60),
        opt("restart_base_s", "float", 0.5, "First restart delay.", min=0.01, max=60),
        opt("restart_max_s", "float", 30.0, "Restart delay cap.", min=0.1, max=3600),
        opt("max_failures", "int", 5,
          "A critical service failing this often in a row puts the robot in estop.",
          min=1, max=1000),
        opt("lag_warn_ms", "float", 100.0, "Event-loop lag above which the loop is unhealthy.",
          min=1, max=60000, tunable=True),
    )),
    SERIAL,
    DRIVE,
    LINE_FOLLOW,
    Section("camera", "The line camera (USB/UVC, Pi camera module, or a recorded video).", (
        opt("source", "str", "uvc", "uvc: V4L2 device; picamera: Pi camera; file: a video.",
          choices=("uvc", "picamera", "file")),
        opt("device", "str", "/dev/video0", "V4L2 device path or index (source = uvc)."),
        opt("file", "str", "", "Video file to replay (source = file)."),
        opt("loop", "bool", False, "Replay the file again from the start when it ends."),
        opt("width", "int", 320, "Frame width in pixels.", min=16, max=4096),
        opt("height", "int", 240, "Frame height in pixels.", min=16, max=4096),
        opt("fps", "float", 30.0, "Capture rate.", min=1, max=240),
    )),
    Section("fleet", "The fleet server: the seed's data exchange, or any robot's site status.", (
        opt("url", "str", "", "Base URL of the fleet server; empty: no fleet server."),
        opt("period_s", "float", 1.0, "Data exchange period.", min=0.1, max=60, tunable=True),
        opt("token_file", "str", "",
            "File holding the robot's bearer token (robotd-fleet token create --robot); "
            "empty: none. Relative or empty with $CREDENTIALS_DIRECTORY set (systemd "
            "LoadCredential=): the credential of that name, fleet-token when empty."),
        opt("ca_file", "str", "",
            "CA certificate (PEM) an https fleet.url's certificate is checked against (a "
            "site's own CA or self-signed certificate); empty: the system's CAs."),
    )),
    Section("safety", "Stopping for what is in front of the robot.", (
        opt("stop_distance_cm", "float", 30.0,
            "Forward motion stops when the front sensor reads less than this.",
            min=0, max=500, tunable=True),
        opt("resume_distance_cm", "float", 40.0,
            "...and resumes once it reads more than this.", min=0, max=500, tunable=True),
        opt("max_reading_age_s", "float", 1.0,
            "A front reading older than this does not count (the robot stops).",
            min=0.05, max=10, tunable=True),
    )),
    Section("ble", "BLE iBeacon scanning, tracking and arrival (seed 000 sections 4, 7).", (
        opt("uuids", "list[str]", [], "iBeacon proximity UUIDs to track; empty: every one."),
        opt("adapter", "str", "", "BlueZ adapter (e.g. hci0); empty: the default one."),
        opt("source", "str", "bluez",
            "Where adverts come from: bluez (the adapter) or stream (JSON lines written to the "
            "named pipe ble.stream, drivers/ble_stream.py).", choices=("bluez", "stream")),
        opt("stream", "str", "", "Named pipe of adverts for ble.source = stream."),
        opt("path_loss_exponent", "float", 2.0,
          "n in d = 10^((TxPower - RSSI) / (10 n)); 2 = free space (the seed).",
          min=1, max=6, tunable=True),
        opt("smoothing_s", "float", 1.0, "Time constant of the RSSI smoothing.",
          min=0, max=30, tunable=True),
        opt("removal_timeout_s", "float", 10.0, "Forget a beacon silent for this long.",
          min=1, max=600, tunable=True),
        opt("enter_margin_db", "float", 0.0, "In target once RSSI >= threshold + this.",
          min=0, max=30, tunable=True),
        opt("enter_hold_s", "float", 0.5,
          "...for this long (sighting time): one noisy stretch does not stop it early.",
          min=0, max=60, tunable=True),
        opt("exit_margin_db", "float", 3.0, "Out of target once RSSI < threshold - this.",
          min=0, max=30, tunable=True),
        opt("exit_hold_s", "float", 2.0,
          "...for this long (sighting time): a parked robot's RSSI noise does not toggle it.",
          min=0, max=60, tunable=True),
        opt("default_rssi_threshold_dbm", "float", -70.0,
          "Threshold of a target beacon the server gave none for.", min=-127, max=20,
          tunable=True),
        opt("stall_timeout_s", "float", 10.0, "Restart the scan when no advert came this long.",
          min=1, max=600),
        opt("restart_max_s", "float", 30.0, "Scanner restart backoff cap.", min=0.1, max=600),
    )),
    HX711,
    LIDAR,
    AUDIO,
    QR_CAMERA,
    *NAV_SECTIONS,
    *NAV_LOCALISATION_SECTIONS,
    Section("docking", "Returning to the dock (seed 001).", (*DOCKING_OPTIONS, *IR_OPTIONS)),
    Section("sim", "The simulated world (hal.backend = sim).", (
        opt("seed", "int", 1, "Random seed for sensor noise.", min=0),
        opt("scenario", "str", "", "Scenario file or built-in name the world comes from."),
    )),
    VIZ,
)

# Limits that only make sense in order: check-config and `robotctl tune set` refuse a value
# that breaks one (to widen a range, move the limit on the outside first).
_CORE_ORDERS: tuple[Order, ...] = (
    Order(("supervisor.restart_base_s", "supervisor.restart_max_s"), strict=False),
    *DRIVE_ORDERS,
    *LINE_FOLLOW_ORDERS,
    Order(("safety.stop_distance_cm", "safety.resume_distance_cm"), strict=False),
    *LIDAR_ORDERS,
    *NAV_LOCALISATION_ORDERS,
    *IR_ORDERS,
    *DOCKING_ORDERS,
)


class _Schema:
    """The sections and orders for a registry, rebuilt when a profile is registered."""

    def __init__(self, registry: ProfileRegistry) -> None:
        self._registry = registry
        self._version = -1
        self._sections: dict[str, Section] = {}
        self._orders: tuple[Order, ...] = ()

    def _fresh(self) -> None:
        if self._version == self._registry.version:
            return
        sections = [_robot_section(self._registry.names()), *_CORE, *self._registry.sections()]
        self._sections = {s.name: s for s in sections}
        self._orders = (*_CORE_ORDERS, *self._registry.orders())
        self._version = self._registry.version

    def sections(self) -> dict[str, Section]:
        self._fresh()
        return self._sections

    def orders(self) -> tuple[Order, ...]:
        self._fresh()
        return self._orders


class _Sections(Mapping[str, Section]):
    def __init__(self, schema: _Schema) -> None:
        self._schema = schema

    def __getitem__(self, name: str) -> Section:
        return self._schema.sections()[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._schema.sections())

    def __len__(self) -> int:
        return len(self._schema.sections())


class _Orders(Sequence[Order]):
    def __init__(self, schema: _Schema) -> None:
        self._schema = schema

    @overload
    def __getitem__(self, index: int) -> Order: ...
    @overload
    def __getitem__(self, index: slice) -> Sequence[Order]: ...
    def __getitem__(self, index: int | slice) -> Order | Sequence[Order]:
        return self._schema.orders()[index]

    def __len__(self) -> int:
        return len(self._schema.orders())


_SCHEMA = _Schema(PROFILES)
SECTIONS: Mapping[str, Section] = _Sections(_SCHEMA)
"""Section name -> Section: the daemon's, the drivers' and every registered profile's."""
ORDERS: Sequence[Order] = _Orders(_SCHEMA)
"""Limits that must rise in order, the daemon's and the profiles'."""
