"""The ``delivery`` config section: the seed's section 9 where it belongs to the delivery robot.

The seed's other values live in the sections of the code that reads them: ``ARDUINO_PORT`` /
``ARDUINO_BAUDRATE`` (COM10, 9600) are the contract's ``serial.port`` / ``serial.baud``
(115200 by default; 9600 with ``serial.framing = "plain"`` for the seed's old sketch);
``LIDAR_*`` is ``lidar``; ``PERSON_DETECTION_*`` is ``people``; ``WHEEL_*`` / ``ENCODER_*`` /
``MAX_SPEED`` are ``drive``; ``LOCALIZATION_UPDATE_RATE`` is ``localisation``; ``AUDIO_DIR`` is
``audio.dir``.
"""

from __future__ import annotations

from behaviours.profiles.delivery import states
from hal.options import Option, Order, Section
from hal.settings import SettingsView

DELIVERY = Section("delivery", "RelayBot, the delivery robot (seed relaybot-delivery-design.md).", (
    Option("database_url", "str", "sqlite:///assets/orders.db",
           "The orders database (the seed's schema); a relative path is under robot.state_dir.",
           pattern=(r"sqlite:///.+", "sqlite:///PATH (an SQLite file)")),
    Option("home_x_m", "float", 0.0, "Home, where the robot waits (the map's origin).",
           min=-1000, max=1000),
    Option("home_y_m", "float", 0.0, "Home, y.", min=-1000, max=1000),
    Option("warehouse_x_m", "float", 5.0, "The warehouse loading zone (seed: (5, 3)).",
           min=-1000, max=1000),
    Option("warehouse_y_m", "float", 3.0, "The warehouse loading zone, y.", min=-1000, max=1000),
    Option("zone_radius_m", "float", 3.0,
           "A person within this distance of home is a customer (DELIVERY_ZONE_RADIUS).",
           min=0.1, max=100, tunable=True),
    Option("position_tolerance_m", "float", 0.1, "A goal is reached this close (10 cm).",
           min=0.01, max=2, tunable=True),
    Option("approach_distance_m", "float", 0.5,
           "Stop this close to the customer and ask for the QR code (< 50 cm).",
           min=0.2, max=3, tunable=True),
    Option("verifying_timeout_s", "float", states.VERIFYING_TIMEOUT_S,
           "No valid QR code this long: back to waiting (QR_SCAN_TIMEOUT; at most the seed's).",
           min=1, max=states.VERIFYING_TIMEOUT_S),
    Option("loading_timeout_s", "float", states.LOADING_TIMEOUT_S,
           "Nobody confirms the loading this long: error recovery "
           "(LOADING_CONFIRMATION_TIMEOUT; at most the seed's).", min=1,
           max=states.LOADING_TIMEOUT_S),
    Option("delivery_duration_s", "float", states.DELIVERY_DURATION_S,
           "The box stays open this long for the customer (DELIVERY_TIMEOUT).", min=1,
           max=states.DELIVERING_TIMEOUT_S),
    Option("delivering_timeout_s", "float", states.DELIVERING_TIMEOUT_S,
           "Hard limit on delivering (the error table's 15 s; the state table keeps the seed's "
           "as its cap).", min=1, max=states.DELIVERING_TIMEOUT_S),
    Option("encoder_freeze_s", "float", 0.5,
           "Wheels driven this long with no encoder tick: encoder failure (LiDAR-only "
           "localisation, half speed).", min=0.1, max=10, tunable=True),
    Option("encoder_min_pwm", "int", 40,
           "Wheel commands at or above this PWM must move the encoders.", min=1, max=255,
           tunable=True),
))

DELIVERY_ORDERS = (Order(("delivery.delivery_duration_s", "delivery.delivering_timeout_s")),)
"""The hand-over must end before its hard limit."""


def timers_from(settings: SettingsView) -> states.Timers:
    """The state timers as configured."""
    return states.Timers(
        verifying_timeout_s=float(settings.get("delivery.verifying_timeout_s")),
        loading_timeout_s=float(settings.get("delivery.loading_timeout_s")),
        delivery_duration_s=float(settings.get("delivery.delivery_duration_s")),
        delivering_timeout_s=float(settings.get("delivery.delivering_timeout_s")),
    )
