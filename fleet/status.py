"""Request statuses of the laundry seed (section 2), spelled as there, and what each one means."""

from __future__ import annotations

from enum import StrEnum


class Status(StrEnum):
    """A request's status; values are the seed's names (a contract)."""

    PENDING = "Pending"
    ACCEPTED = "Accepted"
    ARRIVED_AT_ROOM = "ArrivedAtRoom"
    LAUNDRY_LOADED = "LaundryLoaded"
    WASHING = "Washing"
    GOING_TO_ROOM = "FinishedWashingGoingToRoom"
    ARRIVED_FOR_DELIVERY = "FinishedWashingArrivedAtRoom"
    GOING_TO_BASE = "FinishedWashingGoingToBase"
    COMPLETED = "Completed"
    DECLINED = "Declined"
    CANCELLED = "Cancelled"


class Action(StrEnum):
    """What a customer or an admin can do to a request (`POST /api/requests/{id}/{action}`)."""

    ACCEPT = "accept"
    DECLINE = "decline"
    CANCEL = "cancel"
    CONFIRM_LOADED = "confirm-loaded"
    CONFIRM_UNLOADED = "confirm-unloaded"
    WASHING_STARTED = "washing-started"
    WASHING_DONE = "washing-done"
    PAY = "pay"


TERMINAL = frozenset({Status.COMPLETED, Status.DECLINED, Status.CANCELLED})
ACTIVE = frozenset(Status) - TERMINAL

# Statuses in which the robot is dispatched and serving the request (busy).
ROBOT_SERVING = frozenset({
    Status.ACCEPTED, Status.ARRIVED_AT_ROOM, Status.LAUNDRY_LOADED, Status.GOING_TO_ROOM,
    Status.ARRIVED_FOR_DELIVERY, Status.GOING_TO_BASE,
})

# Statuses in which the robot is travelling (line following on).
TRAVELLING = frozenset({
    Status.ACCEPTED, Status.LAUNDRY_LOADED, Status.GOING_TO_ROOM, Status.GOING_TO_BASE,
})

# Where the robot heads in each travelling status (seed section 5).
HEADS_TO_CUSTOMER = frozenset({Status.ACCEPTED, Status.GOING_TO_ROOM})
HEADS_TO_BASE = frozenset({Status.LAUNDRY_LOADED, Status.GOING_TO_BASE, Status.CANCELLED})

# The statuses from which each action is allowed (seed sections 1, 2 and 12).
ALLOWED: dict[Action, frozenset[Status]] = {
    Action.ACCEPT: frozenset({Status.PENDING}),
    Action.DECLINE: frozenset({Status.PENDING}),
    Action.CANCEL: frozenset({
        Status.PENDING, Status.ACCEPTED, Status.ARRIVED_AT_ROOM, Status.LAUNDRY_LOADED,
        Status.WASHING, Status.GOING_TO_ROOM, Status.ARRIVED_FOR_DELIVERY,
    }),
    Action.CONFIRM_LOADED: frozenset({Status.ARRIVED_AT_ROOM}),
    Action.CONFIRM_UNLOADED: frozenset({Status.ARRIVED_FOR_DELIVERY}),
    Action.WASHING_STARTED: frozenset({Status.WASHING}),
    Action.WASHING_DONE: frozenset({Status.WASHING}),
    # Flowchart 1: the customer pays after Completed. Paying earlier is allowed once the
    # laundry is in the service's hands (loaded); a paid request cancelled from there on gets a
    # refund (section 12). Before that nothing has been done that could be paid for (a request
    # may still be declined, time out or lose its robot).
    Action.PAY: frozenset({
        Status.LAUNDRY_LOADED, Status.WASHING, Status.GOING_TO_ROOM, Status.ARRIVED_FOR_DELIVERY,
        Status.GOING_TO_BASE, Status.COMPLETED,
    }),
}


class Disposition(StrEnum):
    """What happens to the laundry of a cancelled request (seed section 12)."""

    NONE = "None"
    RETURN_DIRTY = "ReturnDirtyToCustomer"
    FINISH_WASHING = "FinishWashingThenDeliverOrReturn"
    HELD_AT_BASE = "CleanLaundryHeldAtBase"
    DIRTY_AT_BASE = "DirtyLaundryAtBase"
    # Cancelled while its robot was offline holding the laundry: still on the robot, until
    # the staff resolve the alert (issue 27).
    ON_ROBOT = "LaundryOnRobot"
    RETURNED_TO_CUSTOMER = "LaundryReturnedToCustomer"


# The robot carries the customer's laundry in these statuses (dirty, then clean).
HOLDS_LAUNDRY = frozenset({Status.LAUNDRY_LOADED, Status.GOING_TO_ROOM,
                           Status.ARRIVED_FOR_DELIVERY})
DIRTY_ABOARD = frozenset({Status.LAUNDRY_LOADED})
CLEAN_ABOARD = frozenset({Status.GOING_TO_ROOM, Status.ARRIVED_FOR_DELIVERY})
