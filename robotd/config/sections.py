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
              choices=("laundry", "delivery", "cabinet", "docking", "square", "idle")),
            opt("state_dir", "str", "/var/lib/robotd",
              "Where mission state and tuning overrides are kept ($STATE_DIRECTORY wins)."),
        )),
        Section("hal", "Hardware backend.", (
            opt("backend", "str", "real", "real: the drivers; sim: the simulated world.",
              choices=("real", "sim")),
            opt("devices", "list[str]", [],
              "Devices to open besides those the profile needs: motors (the Arduino board), "
              "camera, beacons, load_cell, dock_ir, lidar, audio."),
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
        Section("drive", "Wheels, odometry and waypoint driving.", (
            opt("wheel_base_m", "float", 0.30, "Distance between the wheels.", min=0.05, max=2),
            opt("wheel_radius_m", "float", 0.035, "Wheel radius.", min=0.005, max=0.5),
            opt("ticks_per_rev", "int", 360, "Encoder ticks per wheel turn.", min=1, max=100000),
            opt("max_speed_mps", "float", 0.6, "Wheel speed at PWM 255.", min=0.01, max=5),
            opt("deadband_pwm", "int", 20, "PWM below which the wheels do not turn.",
                min=0, max=254),
            opt("cruise_mps", "float", 0.2, "Speed between waypoints.", min=0.01, max=5,
                tunable=True),
            opt("min_mps", "float", 0.03, "Slowest commanded speed.", min=0.001, max=1,
                tunable=True),
            opt("turn_mps", "float", 0.08, "Wheel speed when turning in place.", min=0.01,
                max=2, tunable=True),
            opt("heading_gain", "float", 2.0, "Heading correction (rad/s per rad).", min=0,
                max=50, tunable=True),
            opt("tolerance_m", "float", 0.01, "A waypoint is reached this close.", min=0.001,
                max=1, tunable=True),
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
            opt("stable_s", "float", 1.0, "A verdict needs readings steady for this long.",
              min=0, max=60, tunable=True),
            opt("stable_kg", "float", 0.05, "Largest spread of readings that counts as steady.",
              min=0.001, max=100, tunable=True),
        )),
        Section("ble", "BLE iBeacon scanning, tracking and arrival (seed 000 sections 4, 7).", (
            opt("uuids", "list[str]", [], "iBeacon proximity UUIDs to track; empty: every one."),
            opt("adapter", "str", "", "BlueZ adapter (e.g. hci0); empty: the default one."),
            opt("path_loss_exponent", "float", 2.0,
              "n in d = 10^((TxPower - RSSI) / (10 n)); 2 = free space (the seed).",
              min=1, max=6, tunable=True),
            opt("smoothing_s", "float", 1.0, "Time constant of the RSSI smoothing.",
              min=0, max=30, tunable=True),
            opt("removal_timeout_s", "float", 10.0, "Forget a beacon silent for this long.",
              min=1, max=600, tunable=True),
            opt("enter_margin_db", "float", 0.0, "In target once RSSI >= threshold + this.",
              min=0, max=30, tunable=True),
            opt("exit_margin_db", "float", 3.0, "Out of target once RSSI < threshold - this.",
              min=0, max=30, tunable=True),
            opt("default_rssi_threshold_dbm", "float", -70.0,
              "Threshold of a target beacon the server gave none for.", min=-127, max=20,
              tunable=True),
            opt("stall_timeout_s", "float", 10.0, "Restart the scan when no advert came this long.",
              min=1, max=600),
            opt("restart_max_s", "float", 30.0, "Scanner restart backoff cap.", min=0.1, max=600),
        )),
        Section("hx711", "The HX711 load cell amplifier on two GPIO lines.", (
            opt("gpiochip", "int", 0, "GPIO chip number (/dev/gpiochipN).", min=0, max=64),
            opt("data_gpio", "int", 5, "GPIO line wired to DOUT.", min=0, max=511),
            opt("clock_gpio", "int", 6, "GPIO line wired to PD_SCK.", min=0, max=511),
            opt("gain", "str", "A128", "Channel and gain.", choices=("A128", "A64", "B32")),
            opt("sps", "int", 10, "Output rate the RATE pin selects (10 or 80).", min=10, max=80),
            opt("tare_offset", "int", 0, "Raw reading of the empty bin (robotd probe hx711).",
              min=-8388608, max=8388607, tunable=True),
            opt("calibration_factor", "float", 107374.0,
              "Raw counts per kg (robotd probe hx711 --known-kg); default: 20 kg 1 mV/V cell.",
              min=1e-6, max=1e9, tunable=True),
            opt("average_window", "int", 8, "Readings in the moving average.", min=1, max=256,
              tunable=True),
            opt("median_window", "int", 5, "Readings the outlier check compares against.",
              min=1, max=64),
            opt("outlier_kg", "float", 1.0, "Drop a reading this far from the recent median.",
              min=0.001, max=1000, tunable=True),
            opt("timeout_s", "float", 1.0, "Longest wait for data-ready.", min=0.05, max=10),
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
