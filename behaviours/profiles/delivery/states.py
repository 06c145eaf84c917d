"""RelayBot's nine states and their transitions as data (the seed's state diagram and error table).

States nest under ``mission`` (names relative to it here, dotted paths in transitions); the
seed's EMERGENCY_STOP is the root ``estop``. Callback names are ``MachineModel``'s. Beside the
tables, what each state and transition shows and says: LEDs (property 19), sounds (property 23)
and the box (properties 20, 21), as tables too, and ``outputs_for`` reading them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Final

from behaviours.machine_tables import CoreTrigger, RootState
from hal.readings import LedMode

VERIFYING_TIMEOUT_S = 30.0
"""QR_SCAN_TIMEOUT: no valid code this long → back to waiting (the diagram's 'timeout')."""
LOADING_TIMEOUT_S = 60.0
"""LOADING_CONFIRMATION_TIMEOUT: nobody confirmed the loading → error_recovery (error table)."""
DELIVERY_DURATION_S = 10.0
"""DELIVERY_TIMEOUT: the box stays open exactly this long, then → resetting (property 22)."""
DELIVERING_TIMEOUT_S = 15.0
"""The error table's hard limit on DELIVERING: if the 10 s hand-over has not ended → recovery."""
MAX_RECOVERY_ATTEMPTS = 3
"""Home navigation failing 3 times in error_recovery → estop (error recovery, step 7)."""

BOX_OPEN_DEG = 90
BOX_CLOSED_DEG = 0

WAITING, APPROACHING, VERIFYING = "waiting", "approaching", "verifying"
TO_WAREHOUSE, LOADING = "navigating_to_warehouse", "loading"
TO_CUSTOMER, DELIVERING = "returning_to_customer", "delivering"
RESETTING, ERROR_RECOVERY = "resetting", "error_recovery"
STATES = (WAITING, APPROACHING, VERIFYING, TO_WAREHOUSE, LOADING, TO_CUSTOMER, DELIVERING,
          RESETTING, ERROR_RECOVERY)
"""The seed's nine states, in its order (snake_case of WAITING ... ERROR_RECOVERY)."""


class DeliveryTrigger:
    """The triggers of RelayBot's transitions (the seed's arrows; ``timeout`` is the core's)."""

    PERSON_DETECTED: Final = "person_detected"
    PERSON_LOST: Final = "person_lost"
    REACHED_CUSTOMER: Final = "reached_customer"
    ORDER_VALID: Final = "order_valid"
    ORDER_INVALID: Final = "order_invalid"
    REACHED_WAREHOUSE: Final = "reached_warehouse"
    LOADING_CONFIRMED: Final = "loading_confirmed"
    DELIVERY_COMPLETE: Final = "delivery_complete"
    REACHED_HOME: Final = "reached_home"
    NAVIGATION_ERROR: Final = "navigation_error"
    ERROR: Final = "error"
    RECOVERY_COMPLETE: Final = "recovery_complete"
    RECOVERY_FAILED: Final = "recovery_failed"
    RESUME_DELIVERY: Final = "resume_delivery"
    """After a restart, a parcel in the box: back to the customer (not in the seed)."""
    RESUME_ORDER: Final = "resume_order"
    """After a restart, a verified order not loaded yet: to the warehouse (not in the seed)."""


def path(state: str) -> str:
    """The dotted machine path of one of the nine states."""
    return f"mission.{state}"


NAVIGATING = [path(s) for s in (APPROACHING, TO_WAREHOUSE, TO_CUSTOMER, RESETTING)]
"""The states the diagram sends to ErrorRecovery on a navigation error."""


@dataclass(frozen=True, slots=True)
class Timers:
    """The state timers (the ``delivery`` config section may change them; the seed's here)."""

    verifying_timeout_s: float = VERIFYING_TIMEOUT_S
    loading_timeout_s: float = LOADING_TIMEOUT_S
    delivery_duration_s: float = DELIVERY_DURATION_S
    delivering_timeout_s: float = DELIVERING_TIMEOUT_S


def mission_states(timers: Timers | None = None) -> list[str | dict[str, Any]]:
    """The nine states, waiting first (the mission's initial state); timeouts from the seed."""
    t = timers or Timers()
    return [
        WAITING,
        APPROACHING,
        {"name": VERIFYING, "timeout": t.verifying_timeout_s, "on_timeout": "timed_out"},
        TO_WAREHOUSE,
        {"name": LOADING, "timeout": t.loading_timeout_s, "on_timeout": "timed_out"},
        TO_CUSTOMER,
        {"name": DELIVERING, "timeout": t.delivering_timeout_s, "on_timeout": "timed_out"},
        RESETTING,
        {"name": ERROR_RECOVERY, "on_enter": "stop_motors"},
    ]


def mission_transitions() -> list[dict[str, Any]]:
    """The diagram's arrows, the error table's timeouts, and recovery's way out (to estop)."""
    p, t = path, DeliveryTrigger
    return [
        {"trigger": t.PERSON_DETECTED, "source": p(WAITING), "dest": p(APPROACHING)},
        {"trigger": t.PERSON_LOST, "source": p(APPROACHING), "dest": p(WAITING)},
        {"trigger": t.REACHED_CUSTOMER, "source": p(APPROACHING), "dest": p(VERIFYING)},
        {"trigger": t.ORDER_VALID, "source": p(VERIFYING), "dest": p(TO_WAREHOUSE)},
        {"trigger": t.ORDER_INVALID, "source": p(VERIFYING), "dest": p(WAITING)},
        {"trigger": CoreTrigger.TIMEOUT, "source": p(VERIFYING), "dest": p(WAITING)},
        {"trigger": t.REACHED_WAREHOUSE, "source": p(TO_WAREHOUSE), "dest": p(LOADING)},
        {"trigger": t.LOADING_CONFIRMED, "source": p(LOADING), "dest": p(TO_CUSTOMER)},
        {"trigger": CoreTrigger.TIMEOUT, "source": p(LOADING), "dest": p(ERROR_RECOVERY)},
        {"trigger": t.REACHED_CUSTOMER, "source": p(TO_CUSTOMER), "dest": p(DELIVERING)},
        {"trigger": t.DELIVERY_COMPLETE, "source": p(DELIVERING), "dest": p(RESETTING)},
        {"trigger": CoreTrigger.TIMEOUT, "source": p(DELIVERING), "dest": p(ERROR_RECOVERY)},
        {"trigger": t.REACHED_HOME, "source": p(RESETTING), "dest": p(WAITING)},
        {"trigger": t.NAVIGATION_ERROR, "source": NAVIGATING, "dest": p(ERROR_RECOVERY)},
        {"trigger": t.ERROR, "source": [p(s) for s in STATES if s != ERROR_RECOVERY],
         "dest": p(ERROR_RECOVERY)},
        {"trigger": t.RECOVERY_COMPLETE, "source": p(ERROR_RECOVERY), "dest": p(WAITING)},
        {"trigger": t.RECOVERY_FAILED, "source": p(ERROR_RECOVERY), "dest": RootState.ESTOP},
    ]


# --- what the robot shows and says ------------------------------------------------------------
STATE_LEDS: dict[str, LedMode] = {
    WAITING: LedMode.IDLE,
    APPROACHING: LedMode.MOVING,
    VERIFYING: LedMode.WAITING,
    TO_WAREHOUSE: LedMode.MOVING,
    LOADING: LedMode.WAITING,
    TO_CUSTOMER: LedMode.MOVING,
    DELIVERING: LedMode.WAITING,
    RESETTING: LedMode.MOVING,
    ERROR_RECOVERY: LedMode.FAILURE_SCAN,
}
"""Property 19: the LED command sent on entering each state."""

TRANSITION_LEDS: dict[str, LedMode] = {
    DeliveryTrigger.ORDER_VALID: LedMode.SUCCESS_SCAN,
    DeliveryTrigger.ORDER_INVALID: LedMode.FAILURE_SCAN,
}
"""The seed's existing scan effects, shown before the next state's animation."""

STATE_SOUNDS: dict[str, tuple[str, ...]] = {
    VERIFYING: ("request_qr",),
    LOADING: ("announce_order_{order_id}",),
    DELIVERING: ("delivery_greeting",),
    ERROR_RECOVERY: ("failureScan",),
}
"""Property 23: sounds on entering a state; ``{order_id}`` is the order being served."""

TRANSITION_SOUNDS: dict[str, tuple[str, ...]] = {
    DeliveryTrigger.ORDER_VALID: ("successScan", "order_accepted"),
    DeliveryTrigger.ORDER_INVALID: ("failureScan", "order_rejected"),
}

BOX_ON_ENTER: dict[str, int] = {LOADING: BOX_OPEN_DEG, DELIVERING: BOX_OPEN_DEG,
                                ERROR_RECOVERY: BOX_CLOSED_DEG}
"""Property 20 (open at 90 for loading and delivering); recovery closes the box (step 2)."""
BOX_ON_EXIT: dict[str, int] = {LOADING: BOX_CLOSED_DEG, DELIVERING: BOX_CLOSED_DEG}
"""Property 21: leaving loading (confirmed) or delivering (10 s up) closes the box at 0."""


@dataclass(frozen=True, slots=True)
class Outputs:
    """What one transition makes the robot do, in order: LEDs, box, sounds."""

    leds: tuple[LedMode, ...] = ()
    box_deg: tuple[int, ...] = ()
    sounds: tuple[str, ...] = ()


def outputs_for(source: str, trigger: str, dest: str, order_id: int | None = None) -> Outputs:
    """The LEDs, box moves and sounds of the transition ``source --trigger--> dest``.

    States are names relative to ``mission`` (``loading``); anything else (``estop``,
    ``idle``) has no outputs of its own here.
    """
    leds: list[LedMode] = []
    box: list[int] = []
    sounds: list[str] = []
    if source in BOX_ON_EXIT and source != dest:
        box.append(BOX_ON_EXIT[source])
    if trigger in TRANSITION_LEDS:
        leds.append(TRANSITION_LEDS[trigger])
    sounds.extend(TRANSITION_SOUNDS.get(trigger, ()))
    if dest in STATE_LEDS:
        leds.append(STATE_LEDS[dest])
    if dest in BOX_ON_ENTER and dest != source and BOX_ON_ENTER[dest] not in box[-1:]:
        box.append(BOX_ON_ENTER[dest])
    for sound in STATE_SOUNDS.get(dest, ()):
        sounds.append(sound.format(order_id=order_id if order_id is not None else "unknown"))
    return Outputs(tuple(leds), tuple(box), tuple(sounds))
