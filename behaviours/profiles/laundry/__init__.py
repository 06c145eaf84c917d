"""The laundry robot (seed 000, robot side): line following between rooms, beacons, weight."""

from __future__ import annotations

from behaviours.profile import ProfileSpec
from behaviours.profiles.laundry.config import LAUNDRY, ORDERS, WEIGHT
from behaviours.profiles.laundry.profile import LaundryProfile

SPEC = ProfileSpec(
    LaundryProfile,
    "follows a painted line between rooms, arrives by BLE beacon RSSI, checks the load on an "
    "HX711, driven by the fleet server's 1 s data exchange",
    sections=(LAUNDRY, WEIGHT),
    orders=ORDERS,
)
