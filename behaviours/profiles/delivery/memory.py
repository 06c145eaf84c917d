"""What RelayBot remembers across a crash: the order it serves, where its customer stood, and
whether the parcel is in the box (seed: StateContext; DESIGN.md: the crash-safe store).

Written at each change through the framework's ``MissionRecord`` (``delivery.mission``); the
customer's position is stored when the QR code is verified (property 11) and read for the
return drive. After a restart the mission reads it back: with a parcel in the box it resumes
the delivery or recovers, as the error table says (the mission's part).
"""

from __future__ import annotations

import math
from typing import Any

import structlog

from behaviours.persistence import MissionRecord, Persisted

log = structlog.get_logger(__name__)

DELIVERY_MISSION = MissionRecord("delivery.mission", 1, {
    "order_id": None,           # the verified order being served
    "customer_x_m": None,       # where the customer stood when the code was verified
    "customer_y_m": None,
    "stand_x_m": None,          # where the robot stood for the code: the hand-over spot
    "stand_y_m": None,
    "parcel_in_box": False,     # from loading_confirmed until the hand-over ends
    "delivered_order_id": None,  # the last order handed over (not yet marked in the database?)
    "last_error": None,         # the error category error_recovery last recorded
})


class DeliveryMemory:
    """Typed access to ``delivery.mission``; each change is in the store when the call returns
    (``update``) or queued for the store's writer (``set``)."""

    def __init__(self, persisted: Persisted) -> None:
        self.persisted = persisted

    @property
    def order_id(self) -> int | None:
        value = self.persisted["order_id"]
        return value if isinstance(value, int) else None

    @property
    def parcel_in_box(self) -> bool:
        return bool(self.persisted["parcel_in_box"])

    def customer_position(self) -> tuple[float, float] | None:
        """Where to bring the parcel back to, or None when no order is being served."""
        x, y = self.persisted["customer_x_m"], self.persisted["customer_y_m"]
        if isinstance(x, int | float) and isinstance(y, int | float):
            return float(x), float(y)
        return None

    async def verified(self, order_id: int, customer_x_m: float, customer_y_m: float) -> None:
        """The order is valid; keep it and the customer's position (property 11)."""
        if not (math.isfinite(customer_x_m) and math.isfinite(customer_y_m)):
            msg = f"customer position ({customer_x_m}, {customer_y_m}) is not finite"
            raise ValueError(msg)
        await self.persisted.update(order_id=order_id, customer_x_m=customer_x_m,
                                    customer_y_m=customer_y_m, parcel_in_box=False)
        log.info("delivery.order_kept", order_id=order_id, x_m=customer_x_m, y_m=customer_y_m)

    async def loaded(self) -> None:
        await self.persisted.update(parcel_in_box=True)

    async def handed_over(self) -> None:
        """The hand-over ended: the box is empty and the order done."""
        await self.persisted.update(parcel_in_box=False, delivered_order_id=self.order_id,
                                    order_id=None, customer_x_m=None, customer_y_m=None,
                                    stand_x_m=None, stand_y_m=None)

    async def abandoned(self) -> None:
        """error_recovery dropped the order (a parcel left in the box stays reported)."""
        await self.persisted.update(order_id=None, customer_x_m=None, customer_y_m=None,
                                    stand_x_m=None, stand_y_m=None)

    async def error(self, category: str) -> None:
        await self.persisted.update(last_error=category)

    def values(self) -> dict[str, Any]:
        return self.persisted.values()
