"""The ``delivery`` config section: the seed's section 9 where it belongs to the delivery robot,
each key declared once as a ``DeliveryConfig`` field.

The seed's other values live in the sections of the code that reads them: ``ARDUINO_PORT`` /
``ARDUINO_BAUDRATE`` (COM10, 9600) are the contract's ``serial.port`` / ``serial.baud``
(115200 by default; 9600 with ``serial.framing = "plain"`` for the seed's old sketch);
``LIDAR_*`` is ``lidar``; ``PERSON_DETECTION_*`` is ``people``; ``WHEEL_*`` / ``ENCODER_*`` /
``MAX_SPEED`` are ``drive`` (shared by every robot, so its defaults are not the seed's:
docs/delivery.md, "The seed's configuration", says where they differ and why);
``LOCALIZATION_UPDATE_RATE`` is ``localisation``; ``AUDIO_DIR`` is ``audio.dir``. The error
table's figures (goal unreachable after 30 s, a failed plan retried after 2 s, an obstacle
under 10 cm backed away from by 20 cm) are here.
"""

from __future__ import annotations

from dataclasses import dataclass

from behaviours.profiles.delivery import states
from hal.options import Order, load, section_of, setting
from hal.settings import SettingsView


@dataclass(frozen=True, slots=True)
class DeliveryConfig:
    """The ``delivery`` section."""

    database_url: str = setting(
        "sqlite:///assets/orders.db",
        "The orders database (the seed's schema); a relative path is under robot.state_dir.",
        pattern=(r"sqlite:///.+", "sqlite:///PATH (an SQLite file)"))
    home_x_m: float = setting(0.0, "Home, where the robot waits (the map's origin).",
                              min=-1000, max=1000)
    home_y_m: float = setting(0.0, "Home, y.", min=-1000, max=1000)
    warehouse_x_m: float = setting(5.0, "The warehouse loading zone (seed: (5, 3)).",
                                   min=-1000, max=1000)
    warehouse_y_m: float = setting(3.0, "The warehouse loading zone, y.", min=-1000, max=1000)
    zone_radius_m: float = setting(
        3.0, "A person within this distance of home is a customer (DELIVERY_ZONE_RADIUS).",
        min=0.1, max=100, tunable=True)
    position_tolerance_m: float = setting(0.1, "A goal is reached this close (10 cm).",
                                          min=0.01, max=2, tunable=True)
    approach_distance_m: float = setting(
        0.5, "Stop this close to the customer and ask for the QR code (< 50 cm).",
        min=0.2, max=3, tunable=True)
    verifying_timeout_s: float = setting(
        states.VERIFYING_TIMEOUT_S,
        "No valid QR code this long: back to waiting (QR_SCAN_TIMEOUT; at most the seed's).",
        min=1, max=states.VERIFYING_TIMEOUT_S)
    loading_timeout_s: float = setting(
        states.LOADING_TIMEOUT_S,
        "Nobody confirms the loading this long: error recovery "
        "(LOADING_CONFIRMATION_TIMEOUT; at most the seed's).", min=1,
        max=states.LOADING_TIMEOUT_S)
    delivery_duration_s: float = setting(
        states.DELIVERY_DURATION_S,
        "The box stays open this long for the customer (DELIVERY_TIMEOUT).", min=1,
        max=states.DELIVERING_TIMEOUT_S)
    delivering_timeout_s: float = setting(
        states.DELIVERING_TIMEOUT_S,
        "Hard limit on delivering (the error table's 15 s; the state table keeps the seed's "
        "as its cap).", min=1, max=states.DELIVERING_TIMEOUT_S)
    encoder_freeze_s: float = setting(
        0.5, "Wheels driven this long with no encoder tick: encoder failure (LiDAR-only "
        "localisation, half speed).", min=0.1, max=10, tunable=True)
    encoder_min_pwm: int = setting(
        40, "Wheel commands at or above this PWM must move the encoders.", min=1, max=255,
        tunable=True)
    stuck_s: float = setting(
        30.0, "Goal unreachable: no progress this long (the error table's 30 s) before an "
        "alternate path is tried; the planner's own no_progress_s only makes it plan again.",
        min=1, max=600, tunable=True)
    plan_retry_s: float = setting(
        2.0, "Path planning failure: wait this long, then plan once more with relaxed "
        "constraints (the error table's 2 s).", min=0, max=60, tunable=True)
    relaxed_clearance_m: float = setting(
        0.20, "The relaxed constraint of that retry: the planner's clearance (planner."
        "clearance_m, 0.30) down to this (never up to it).", min=0.0, max=5.0, tunable=True)
    obstacle_cm: float = setting(
        10.0, "Obstacle collision: the front IR sensor reading less than this while driving "
        "stops the robot, which backs away and plans again (the error table's 10 cm).",
        min=1, max=100, tunable=True)
    back_up_m: float = setting(
        0.20, "... backing this far (the error table's 20 cm), less when the LiDAR sees "
        "something behind.", min=0.0, max=2.0, tunable=True)
    hand_cm: float = setting(
        15.0, "While the box is open for the customer, the front IR sensor reading less than "
        "this is a hand in the box opening: the hand-over waits (never past its hard "
        "limit) and the box does not close on it.", min=1, max=100, tunable=True)

    @classmethod
    def from_settings(cls, settings: SettingsView) -> DeliveryConfig:
        return load(cls, settings.section(DELIVERY.name))


DELIVERY = section_of(DeliveryConfig, "delivery",
                      "RelayBot, the delivery robot (seed relaybot-delivery-design.md).")

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
