"""RelayBot, the delivery robot (seed relaybot-delivery-design.md, issue 17)."""

from __future__ import annotations

from behaviours.profile import CtlCommand, CtlOption, ProfileSpec
from behaviours.profiles.delivery.config import DELIVERY, DELIVERY_ORDERS
from behaviours.profiles.delivery.config_files import delivery_file_problems
from behaviours.profiles.delivery.profile import DeliveryProfile

SPEC = ProfileSpec(
    DeliveryProfile,
    "waits at home, drives up to a customer the LiDAR sees in its zone, checks the order's QR "
    "code, fetches the parcel from the warehouse and hands it over from its servo box",
    sections=(DELIVERY,),
    orders=DELIVERY_ORDERS,
    file_checks=(delivery_file_problems,),
    commands=(CtlCommand("confirm-loaded", "delivery robot: the parcel is in the box "
                         "(warehouse staff)", "delivery.confirm_loaded",
                         (CtlOption("--by", "robotctl", "who confirms (kept in the event)"),)),),
)
