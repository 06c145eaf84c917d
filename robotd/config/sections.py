"""Every configuration section and key robotd knows, as one table (unknown keys are errors).

The contract keys of DESIGN.md are here with the same names; the others are ours to extend.
A module that needs settings adds its section here, so ``check-config`` knows it without
building any hardware.
"""

from __future__ import annotations

from robotd.config.schema import Option, Section

opt = Option

SECTIONS: dict[str, Section] = {
    s.name: s
    for s in (
        Section("robot", "Who this robot is.", (
            opt("name", "str", "robot-1", "Robot name, as the fleet server knows it.", min=1),
            opt("profile", "str", "laundry", "Which robot this is.",
              choices=("laundry", "delivery", "cabinet", "docking", "square")),
            opt("state_dir", "str", "/var/lib/robotd",
              "Where mission state and tuning overrides are kept ($STATE_DIRECTORY wins)."),
        )),
        Section("hal", "Hardware backend.", (
            opt("backend", "str", "real", "real: the drivers; sim: the simulated world.",
              choices=("real", "sim")),
        )),
        Section("control", "The local control socket for robotctl.", (
            opt("socket", "str", "/run/robotd/control.sock", "Unix socket path."),
            opt("max_clients", "int", 64, "Connections accepted at once.", min=1, max=4096),
            opt("client_queue", "int", 256, "Notifications queued per client before it loses some.",
              min=1, max=100000),
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
        Section("serial", "The Arduino motor board link.", (
            opt("port", "str", "/dev/ttyACM0", "Serial device."),
            opt("baud", "int", 115200, "Baud rate.", min=1200, max=2000000),
            opt("framing", "str", "crc", "crc: #SEQ and CRC-8; plain: the seed's bare lines.",
              choices=("crc", "plain")),
            opt("ack_timeout_s", "float", 0.5, "Resend a command not acknowledged in this time.",
              min=0.01, max=10),
            opt("max_resends", "int", 3, "Resends before a command counts as lost.", min=0, max=20),
            opt("heartbeat_s", "float", 0.2, "Heartbeat period (MCU stops after 0.5 s silence).",
              min=0.05, max=0.45),
            opt("queue_limit", "int", 10, "Non-critical commands queued before dropping.",
              min=1, max=1000),
            opt("reconnect_max_s", "float", 5.0, "Reconnect backoff cap.", min=0.1, max=300),
            opt("min_firmware_protocol", "int", 1, "Lowest protocol version accepted in HELLO.",
              min=0, max=255),
        )),
        Section("line_follow", "Camera line following (seed 000 section 6).", (
            opt("kp", "float", 0.5, "Proportional gain.", min=0, max=100, tunable=True),
            opt("ki", "float", 0.0, "Integral gain.", min=0, max=100, tunable=True),
            opt("kd", "float", 0.1, "Derivative gain.", min=0, max=100, tunable=True),
            opt("fps", "float", 13.0, "Control loop rate (13 = the seed's 77 ms).", min=1, max=120,
              tunable=True),
        )),
        Section("fleet", "The fleet server's data exchange (seed 000 section 8).", (
            opt("url", "str", "", "Base URL of the fleet server; empty: no fleet server."),
            opt("period_s", "float", 1.0, "Data exchange period.", min=0.1, max=60, tunable=True),
        )),
        Section("weight", "Load check with the HX711 (seed 000 section 11).", (
            opt("min_kg", "float", 0.5, "Below this the bin is empty.", min=0, max=1000,
              tunable=True),
            opt("max_kg", "float", 10.0, "Above this the load is too heavy.", min=0, max=1000,
              tunable=True),
        )),
        Section("docking", "Returning to the dock (seed 001).", (
            opt("battery_threshold_pct", "float", 20.0, "Go to the dock below this charge.",
              min=0, max=100, tunable=True),
        )),
        Section("sim", "The simulated world (hal.backend = sim).", (
            opt("seed", "int", 1, "Random seed for sensor noise.", min=0),
            opt("scenario", "str", "", "Scenario file or built-in name the world comes from."),
        )),
    )
}
