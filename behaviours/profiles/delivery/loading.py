"""Who confirms that the parcel is in the box: warehouse staff, through the control socket.

The seed leaves it open; a worker runs ``robotctl confirm-loaded`` (control method
``delivery.confirm_loaded``), which fires ``loading_confirmed`` while the robot is in
``mission.loading`` and is refused, with the state named, at any other time.
"""

from __future__ import annotations

from typing import Any

from behaviours.context import RobotContext
from behaviours.profile import ControlMethod, ControlRefused
from behaviours.profiles.delivery.states import LOADING, DeliveryTrigger, path

MAX_BY_CHARS = 64


class LoadingConfirmation:
    """The ``delivery.confirm_loaded`` control method over a robot context."""

    def __init__(self, ctx: RobotContext) -> None:
        self.ctx = ctx
        self.confirmations = 0

    def methods(self) -> dict[str, ControlMethod]:
        return {"delivery.confirm_loaded": self.confirm_loaded}

    async def confirm_loaded(self, params: dict[str, Any]) -> dict[str, Any]:
        unknown = sorted(set(params) - {"by"})
        if unknown:
            msg = f"unknown params {unknown} (known: by)"
            raise ValueError(msg)
        by = params.get("by", "robotctl")
        if not isinstance(by, str) or not 0 < len(by) <= MAX_BY_CHARS:
            msg = f"by: expected a name of 1-{MAX_BY_CHARS} characters"
            raise ValueError(msg)
        state = self.ctx.state
        if state != path(LOADING):
            msg = f"not waiting for a parcel (state {state}); nothing confirmed"
            raise ControlRefused(msg)
        if not await self.ctx.trigger(DeliveryTrigger.LOADING_CONFIRMED, by=by):
            msg = f"loading_confirmed refused in state {self.ctx.state}"
            raise ControlRefused(msg)
        self.confirmations += 1
        self.ctx.emit("delivery.loading_confirmed", by=by)
        return {"state": self.ctx.state, "by": by}
