"""The laundry profile's own config sections: ``laundry`` and ``weight`` (its load check)."""

from __future__ import annotations

from hal.options import Option, Order, Section

LAUNDRY = Section(
    "laundry",
    "The laundry robot (seed 000, robot side).",
    (
        Option("base_room", "str", "base", "Room name of the base (laundry room) beacons."),
        Option(
            "base_queue_db",
            "float",
            10.0,
            "Heading to base and held by the robot ahead, the robot is queued at base (no "
            "'blocked' fault; IsInTarget) while it hears a base beacon at most this far "
            "below its threshold. The fleet server's BaseQueueMarginDb must be as large.",
            min=0,
            max=60,
            tunable=True,
        ),
        Option(
            "server_grace_s",
            "float",
            5.0,
            "Without an answer from the fleet server this long, stop line following.",
            min=0.5,
            max=600,
            tunable=True,
        ),
        Option(
            "route",
            "list[str]",
            [],
            'Without a fleet server: rooms to visit in turn (e.g. ["103", "base"]).',
        ),
        Option(
            "beacons",
            "table",
            {},
            "Without a fleet server: MAC -> { room, rssi_threshold_dbm, name }.",
        ),
        Option("follow_color", "str", "", "Without a fleet server: the line colour to follow."),
        Option(
            "load_wait_s",
            "float",
            300.0,
            "Without a fleet server: longest wait for a load at a room.",
            min=0,
            max=86400,
            tunable=True,
        ),
    ),
)

WEIGHT = Section(
    "weight",
    "Load check with the HX711 (seed 000 section 11).",
    (
        Option(
            "min_kg", "float", 0.5, "Below this the bin is empty.", min=0, max=1000, tunable=True
        ),
        Option(
            "max_kg",
            "float",
            10.0,
            "Above this the load is too heavy.",
            min=0,
            max=1000,
            tunable=True,
        ),
        Option(
            "stable_s",
            "float",
            1.0,
            "A verdict needs readings steady for this long.",
            min=0,
            max=60,
            tunable=True,
        ),
        Option(
            "stable_kg",
            "float",
            0.05,
            "Largest spread of readings that counts as steady.",
            min=0.001,
            max=100,
            tunable=True,
        ),
    ),
)

ORDERS = (Order(("weight.min_kg", "weight.max_kg")),)
"""Limits that only make sense in order (check-config and ``tune.set`` refuse the others)."""
