"""Every configuration section and key robotd knows, as one table (unknown keys are errors).

The contract keys of DESIGN.md are here with the same names; the others are ours to extend.
A module that needs settings adds its section here, so ``check-config`` knows it without
building any hardware.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from robotd.config.schema import Option, Order, Section

opt = Option

IR_RECEIVER_GPIOS = {"omni": 17, "front_left": 27, "front_right": 22, "side_left": 23,
                     "side_right": 24, "rear": 25}
"""The dock IR receivers (drivers.dock_ir.RECEIVERS) and their default BCM GPIO lines."""

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
            opt("handshake_timeout_s", "float", 3.0,
              "Time the board gets to answer HELLO after the port opens (resets take ~2 s).",
              min=0.1, max=60),
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
            opt("band_forward_px", "float", 30.0, "Below this error: straight on at full speed.",
              min=0, max=10000, tunable=True),
            opt("band_gentle_px", "float", 80.0, "Below this: gentle correction.", min=0, max=10000,
              tunable=True),
            opt("band_strong_px", "float", 150.0,
                "Below this: strong correction; above: full turn.",
              min=0, max=10000, tunable=True),
            opt("speed", "float", 0.55, "Wheel duty (0-1) when straight on.", min=0, max=1,
              tunable=True),
            opt("gentle_speed", "float", 0.8, "Speed in the gentle band, fraction of speed.",
              min=0, max=1, tunable=True),
            opt("strong_speed", "float", 0.5, "Speed in the strong band, fraction of speed.",
              min=0, max=1, tunable=True),
            opt("turn_speed", "float", 0.4, "Wheel duty of a full turn and of the recovery turn.",
              min=0, max=1, tunable=True),
            opt("max_integral", "float", 0.3, "Anti-windup: cap of the integral term (duty).",
              min=0, max=1, tunable=True),
            opt("lost_frames", "int", 20, "Frames without the line before stopping with an error.",
              min=1, max=1000, tunable=True),
            opt("colour", "str", "black", "Line colour when the fleet server names none.",
              choices=("black", "white", "red", "green", "blue", "yellow", "cyan", "magenta"),
              tunable=True),
            opt("roi_top", "float", 0.25, "Top of the scanned band, fraction of the image height.",
              min=0, max=1, tunable=True),
            opt("roi_bottom", "float", 0.6, "Bottom of the scanned band (> roi_top).", min=0, max=1,
              tunable=True),
            opt("min_contrast", "float", 0.2, "Contrast against the floor that counts as line.",
              min=0.01, max=1, tunable=True),
        )),
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
        Section("fleet", "The fleet server's data exchange (seed 000 section 8).", (
            opt("url", "str", "", "Base URL of the fleet server; empty: no fleet server."),
            opt("period_s", "float", 1.0, "Data exchange period.", min=0.1, max=60, tunable=True),
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
        Section("laundry", "The laundry robot (seed 000, robot side).", (
            opt("base_room", "str", "base", "Room name of the base (laundry room) beacons."),
            opt("server_grace_s", "float", 5.0,
                "Without an answer from the fleet server this long, stop line following.",
                min=0.5, max=600, tunable=True),
            opt("route", "list[str]", [],
                "Without a fleet server: rooms to visit in turn (e.g. [\"103\", \"base\"])."),
            opt("beacons", "table", {},
                "Without a fleet server: MAC -> { room, rssi_threshold_dbm, name }."),
            opt("follow_color", "str", "", "Without a fleet server: the line colour to follow."),
            opt("load_wait_s", "float", 300.0,
                "Without a fleet server: longest wait for a load at a room.", min=0, max=86400,
                tunable=True),
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
        Section("hx711", "The HX711 load cell amplifier on two GPIO lines.", (
            opt("gpiochip", "int", 0, "GPIO chip number (/dev/gpiochipN).", min=0, max=64),
            opt("data_gpio", "int", 5, "GPIO line wired to DOUT.", min=0, max=511),
            opt("clock_gpio", "int", 6, "GPIO line wired to PD_SCK.", min=0, max=511),
            opt("gain", "str", "A128", "Channel and gain.", choices=("A128", "A64", "B32")),
            opt("sps", "int", 10, "Output rate the RATE pin selects.", choices=(10, 80)),
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
            opt("ir_window_s", "float", 0.2,
                "A dock IR code stays seen this long after it was decoded (OR over a window).",
                min=0.02, max=5, tunable=True),
            opt("ir_gpiochip", "int", 0, "GPIO chip of the IR receivers (/dev/gpiochipN).",
                min=0, max=64),
            *(opt(f"ir_gpio_{receiver}", "int", gpio,
                  f"GPIO line of the {receiver.replace('_', ' ')} IR receiver; -1: not fitted.",
                  min=-1, max=511)
              for receiver, gpio in IR_RECEIVER_GPIOS.items()),
            opt("ir_active_low", "bool", True,
                "The receivers pull their output low while they see the carrier (TSOP-style)."),
            opt("ir_tolerance_pct", "float", 25.0, "Tolerance of each IR pulse width.",
                min=5, max=40),
            opt("ir_codes", "table", {"force_field": 161, "green_buoy": 164, "red_buoy": 168,
                                      "virtual_wall": 162},
                "Dock beam name -> 8-bit IR code (defaults: the iRobot OI home base, virtual "
                "wall); each code once."),
            opt("ir_combined", "list[str]", ["force_field", "green_buoy", "red_buoy"],
                "Beams whose codes OR into a combination code when a receiver is in several "
                "(OI: 161 | 164 = 165)."),
        )),
        Section("sim", "The simulated world (hal.backend = sim).", (
            opt("seed", "int", 1, "Random seed for sensor noise.", min=0),
            opt("scenario", "str", "", "Scenario file or built-in name the world comes from."),
        )),
    )
}

class DistinctCodes(Order):
    """``docking.ir_codes`` with ``docking.ir_combined``: each code 0-255 and given once, the
    OR combinations included (a code twice would make two beams one). An Order, so that
    check-config runs it with the limits at the line of the key: the generic machinery has no
    per-value check (schema.Option would want a ``validate`` hook)."""

    def problem(self, get: Callable[[str], Any], changed: str | None = None
                ) -> tuple[str, str] | None:
        from drivers.dock_ir.oi_codes import table_problem

        why = table_problem(get(self.keys[0]), get(self.keys[1]))
        return None if why is None else (self.keys[0], why)


# Limits that only make sense in order: check-config and `robotctl tune set` refuse a value
# that breaks one (to widen a range, move the limit on the outside first).
ORDERS: tuple[Order, ...] = (
    Order(("supervisor.restart_base_s", "supervisor.restart_max_s"), strict=False),
    Order(("drive.min_mps", "drive.cruise_mps"), strict=False),
    Order(("line_follow.band_forward_px", "line_follow.band_gentle_px",
           "line_follow.band_strong_px")),
    Order(("line_follow.roi_top", "line_follow.roi_bottom")),
    Order(("safety.stop_distance_cm", "safety.resume_distance_cm"), strict=False),
    Order(("weight.min_kg", "weight.max_kg")),
    DistinctCodes(("docking.ir_codes", "docking.ir_combined")),
)
