"""RelayBot, the delivery robot (seed relaybot-delivery-design.md, issue 17)."""

from __future__ import annotations

from behaviours.profile import ProfileSpec
from behaviours.profiles.delivery.config import DELIVERY, DELIVERY_ORDERS
from behaviours.profiles.delivery.profile import DeliveryProfile

SPEC = ProfileSpec(
    DeliveryProfile,
    "waits at home, drives up to a customer the LiDAR sees in its zone, checks the order's QR "
    "code, fetches the parcel from the warehouse and hands it over from its servo box",
    sections=(DELIVERY,),
    orders=DELIVERY_ORDERS,
    sim_actors="robotd.sim.actors.delivery:DeliveryActors.for_scenario",
)
