"""RelayBot's simulator slice: QR camera, speaker, people, conditions, scenarios.

The people are customers and warehouse staff; the conditions are the sounds, the box and the
hand-over, drawn by its report layer."""

from __future__ import annotations

from sim.nav.checks import NavCheck
from sim.robots.delivery.actions import DELIVERY_ACTIONS
from sim.robots.delivery.checks import DeliveryCheck
from sim.robots.delivery.devices import fit_qr_and_audio
from sim.robots.delivery.report import draw_delivery
from sim.slice import SimSlice

SIM = SimSlice(
    actors="sim.robots.delivery.actors:DeliveryActors.for_scenario",
    checks=(NavCheck(), DeliveryCheck()),
    layers=(draw_delivery,),
    actions=DELIVERY_ACTIONS,
    fit_devices=fit_qr_and_audio,
    scenario_tables={"delivery": None},
)
