"""The ``docking`` root state as data: the seed's phases, sub-steps and position cases.

Names are the seed's (ir-docking-flowcharts.md), snake_case, nested under ``docking``:
section 1's four phases (``search``, ``approach``, ``align``, ``dock``), section 2's position
cases (``position``: ``scan_beams`` and the left/right/front/rear approaches), section 5's
station sequence (``charging``, ``emptying``, ``standby``, ``undock``). Every loop of the
diagrams is a transition of its own, so each pass round it is logged.

Section 4's errors are triggers (``align_lost``, ``contact_failed``, ``voltage_abnormal``,
``signal_lost``, ``timeout``); each has three rows, tried in order: retry (fewer than 3
failures), fall back to wall following (the count starts again), or give up to ``recovery``
once ``docking.max_fallbacks`` fallbacks were spent. The counting is the machine model's
(``count_dock_failure``, ``may_retry_docking``, ``may_fall_back``; ``behaviours.docking.attempts``).
"""

from __future__ import annotations

from typing import Any, Final

from behaviours.machine_tables import CoreTrigger, RootState


class DockState:
    """Every docking state's dotted path (the names in logs, events and tests).

    Plain ``str`` constants (``transitions`` would take an Enum state by its member name).
    ``docking_states()`` nests each under the path before its last dot.
    """

    DOCKING: Final = RootState.DOCKING
    # Section 1, phase 1.
    SEARCH: Final = "docking.search"
    WALL_FOLLOW: Final = "docking.search.wall_follow"
    FORCE_FIELD_DETECT: Final = "docking.search.force_field_detect"
    DIRECTION_TURN: Final = "docking.search.direction_turn"
    # Section 2.
    POSITION: Final = "docking.position"
    SCAN_BEAMS: Final = "docking.position.scan_beams"
    LEFT_APPROACH: Final = "docking.position.left_approach"
    TURN_LEFT: Final = "docking.position.left_approach.turn_left"
    FORWARD_L: Final = "docking.position.left_approach.forward_l"
    FRONT_R_ENTRY: Final = "docking.position.left_approach.front_r_entry"
    OVERLAP_L: Final = "docking.position.left_approach.overlap_l"
    RIGHT_APPROACH: Final = "docking.position.right_approach"
    TURN_RIGHT: Final = "docking.position.right_approach.turn_right"
    FORWARD_R: Final = "docking.position.right_approach.forward_r"
    FRONT_L_ENTRY: Final = "docking.position.right_approach.front_l_entry"
    OVERLAP_R: Final = "docking.position.right_approach.overlap_r"
    FRONT_APPROACH: Final = "docking.position.front_approach"
    CHECK_SKEW: Final = "docking.position.front_approach.check_skew"
    SKEW_LEFT: Final = "docking.position.front_approach.skew_left"
    SKEW_RIGHT: Final = "docking.position.front_approach.skew_right"
    CORRECT_RIGHT: Final = "docking.position.front_approach.correct_right"
    CORRECT_LEFT: Final = "docking.position.front_approach.correct_left"
    CENTERED: Final = "docking.position.front_approach.centered"
    REAR_APPROACH: Final = "docking.position.rear_approach"
    TURN180: Final = "docking.position.rear_approach.turn180"
    FRONT_NOW: Final = "docking.position.rear_approach.front_now"
    # Section 1, phase 2.
    APPROACH: Final = "docking.approach"
    FRONT_BEAM_DETECT: Final = "docking.approach.front_beam_detect"
    LEFT_ONLY: Final = "docking.approach.left_only"
    RIGHT_ONLY: Final = "docking.approach.right_only"
    MICRO_RIGHT: Final = "docking.approach.micro_right"
    MICRO_LEFT: Final = "docking.approach.micro_left"
    BOTH_BEAMS: Final = "docking.approach.both_beams"
    OVERLAP_ZONE: Final = "docking.approach.overlap_zone"
    # Phase 3.
    ALIGN: Final = "docking.align"
    CENTER_BEAM_SEARCH: Final = "docking.align.center_beam_search"
    FINE_ALIGN: Final = "docking.align.fine_align"
    SIGNAL_COMPARE: Final = "docking.align.signal_compare"
    LEFT_STRONGER: Final = "docking.align.left_stronger"
    RIGHT_STRONGER: Final = "docking.align.right_stronger"
    MICRO_ADJUST_R: Final = "docking.align.micro_adjust_r"
    MICRO_ADJUST_L: Final = "docking.align.micro_adjust_l"
    BALANCED: Final = "docking.align.balanced"
    # Phase 4.
    DOCK: Final = "docking.dock"
    SLOW_FORWARD: Final = "docking.dock.slow_forward"
    CONTACT_CHECK: Final = "docking.dock.contact_check"
    ALIGN_CHECK: Final = "docking.dock.align_check"
    VOLTAGE_DETECT: Final = "docking.dock.voltage_detect"
    MOTOR_STOP: Final = "docking.dock.motor_stop"
    RETRY: Final = "docking.dock.retry"
    # Section 5.
    CHARGING: Final = "docking.charging"
    EMPTYING: Final = "docking.emptying"
    DOOR_OPEN: Final = "docking.emptying.door_open"
    VACUUM_ON: Final = "docking.emptying.vacuum_on"
    WAIT_EMPTY: Final = "docking.emptying.wait_empty"
    VACUUM_OFF: Final = "docking.emptying.vacuum_off"
    DOOR_CLOSE: Final = "docking.emptying.door_close"
    STANDBY: Final = "docking.standby"
    UNDOCK: Final = "docking.undock"


class DockTrigger:
    """The triggers of the docking transitions (``timeout`` is the core's)."""

    # Section 1, phase 1.
    BEAM_DETECTED: Final = "beam_detected"
    FIELD_LOST: Final = "field_lost"
    FIELD_DETECTED: Final = "field_detected"
    DIRECTION_FOUND: Final = "direction_found"
    # Section 2 (the scan's cases are ``beams.position_case``'s, the skews ``skew_case``'s).
    FAR_RIGHT_SEEN: Final = "far_right_seen"
    FAR_LEFT_SEEN: Final = "far_left_seen"
    FRONT_SEEN: Final = "front_seen"
    REAR_SEEN: Final = "rear_seen"
    TURNED: Final = "turned"
    FRONT_BEAM_ENTERED: Final = "front_beam_entered"
    OVERLAP_REACHED: Final = "overlap_reached"
    SKEW_LEFT: Final = "skew_left"
    SKEW_RIGHT: Final = "skew_right"
    CENTERED: Final = "centered"
    CORRECT: Final = "correct"
    CORRECTED: Final = "corrected"
    FRONT_READY: Final = "front_ready"
    # Phase 2 (the front cases are ``beams.front_case``'s).
    FRONT_LEFT_ONLY: Final = "front_left_only"
    FRONT_RIGHT_ONLY: Final = "front_right_only"
    FRONT_BOTH: Final = "front_both"
    MICRO_TURN: Final = "micro_turn"
    IN_OVERLAP: Final = "in_overlap"
    APPROACHED: Final = "approached"
    # Phase 3 (the compare's cases are ``beams.signal_case``'s).
    CENTER_FOUND: Final = "center_found"
    COMPARE: Final = "compare"
    LEFT_STRONGER: Final = "left_stronger"
    RIGHT_STRONGER: Final = "right_stronger"
    BALANCED: Final = "balanced"
    ADJUST: Final = "adjust"
    ADJUSTED: Final = "adjusted"
    ALIGNED: Final = "aligned"
    # Phase 4.
    TOUCHED: Final = "touched"
    CONTACT_MADE: Final = "contact_made"
    NO_CONTACT: Final = "no_contact"
    ALIGNMENT_OK: Final = "alignment_ok"
    VOLTAGE_OK: Final = "voltage_ok"
    STOPPED: Final = "stopped"
    BACKED_OFF: Final = "backed_off"
    # Section 4's errors.
    ALIGN_LOST: Final = "align_lost"
    CONTACT_FAILED: Final = "contact_failed"
    VOLTAGE_ABNORMAL: Final = "voltage_abnormal"
    SIGNAL_LOST: Final = "signal_lost"
    DOCK_IR_LOST: Final = "dock_ir_lost"
    # Section 5.
    BIN_FULL: Final = "bin_full"
    DOOR_OPENED: Final = "door_opened"
    SUCTION_ON: Final = "suction_on"
    BIN_EMPTIED: Final = "bin_emptied"
    SUCTION_OFF: Final = "suction_off"
    DOOR_CLOSED: Final = "door_closed"
    CHARGED: Final = "charged"
    CONTACTS_LOST: Final = "contacts_lost"
    CLEAN_SCHEDULED: Final = "clean_scheduled"
    UNDOCKED: Final = "undocked"
    RESUME_CHARGING: Final = "resume_charging"
    GO_DOCK: Final = "go_dock"


S, T = DockState, DockTrigger

SEARCH_TIMEOUT_S = 180.0
STEP_TIMEOUT_S = 60.0
"""position, approach, align, dock: each must finish within this (a failure 903/905)."""
EMPTYING_TIMEOUT_S = 90.0
WAIT_EMPTY_MAX_S = 30.0
"""The seed's 10-30 s: ``wait_empty`` ends at the latest after this."""
UNDOCK_TIMEOUT_S = 30.0

FALLBACK_STATE = S.SEARCH
"""Wall following again: ``search`` is entered anew (its timeout restarts) at ``wall_follow``."""
STEPS = [S.POSITION, S.APPROACH, S.ALIGN, S.DOCK]


def _name(path: str, parent: str) -> str:
    """A state's name in its parent's ``children`` (its path after the parent's)."""
    parent_path, _, name = path.rpartition(".")
    if parent_path != parent:
        msg = f"docking table: {path!r} is not a child of {parent!r}"
        raise ValueError(msg)
    return name


def _nest(path: str, children: list[Any], **extra: Any) -> dict[str, Any]:
    named = [_name(c, path) if isinstance(c, str) else c for c in children]
    first = named[0]
    return {"name": path.rpartition(".")[2], "children": named,
            "initial": first if isinstance(first, str) else first["name"], **extra}


def _leaf(path: str, **extra: Any) -> dict[str, Any]:
    return {"name": path.rpartition(".")[2], **extra}


def _timed(timeout_s: float) -> dict[str, Any]:
    return {"timeout": timeout_s, "on_timeout": "timed_out"}


def docking_states() -> list[str | dict[str, Any]]:
    """The children of ``docking``, in the seed's order."""
    return [
        # Section 1, phase 1.
        _nest(S.SEARCH, [S.WALL_FOLLOW, S.FORCE_FIELD_DETECT, S.DIRECTION_TURN],
              **_timed(SEARCH_TIMEOUT_S)),
        # Section 2: where the robot is decides how it comes in.
        _nest(S.POSITION, [
            S.SCAN_BEAMS,
            _nest(S.LEFT_APPROACH, [S.TURN_LEFT, S.FORWARD_L, S.FRONT_R_ENTRY, S.OVERLAP_L]),
            _nest(S.RIGHT_APPROACH, [S.TURN_RIGHT, S.FORWARD_R, S.FRONT_L_ENTRY, S.OVERLAP_R]),
            _nest(S.FRONT_APPROACH, [S.CHECK_SKEW, S.SKEW_LEFT, S.SKEW_RIGHT, S.CORRECT_RIGHT,
                                     S.CORRECT_LEFT, S.CENTERED]),
            _nest(S.REAR_APPROACH, [S.TURN180, S.FRONT_NOW]),
        ], **_timed(STEP_TIMEOUT_S)),
        # Section 1, phases 2-4.
        _nest(S.APPROACH, [S.FRONT_BEAM_DETECT, S.LEFT_ONLY, S.RIGHT_ONLY, S.MICRO_RIGHT,
                           S.MICRO_LEFT, S.BOTH_BEAMS, S.OVERLAP_ZONE], **_timed(STEP_TIMEOUT_S)),
        _nest(S.ALIGN, [S.CENTER_BEAM_SEARCH, S.FINE_ALIGN, S.SIGNAL_COMPARE, S.LEFT_STRONGER,
                        S.RIGHT_STRONGER, S.MICRO_ADJUST_R, S.MICRO_ADJUST_L, S.BALANCED],
              **_timed(STEP_TIMEOUT_S)),
        _nest(S.DOCK, [S.SLOW_FORWARD, S.CONTACT_CHECK, S.ALIGN_CHECK, S.VOLTAGE_DETECT,
                       S.MOTOR_STOP, S.RETRY], **_timed(STEP_TIMEOUT_S)),
        # Section 5: the station.
        _leaf(S.CHARGING, on_enter="stop_motors"),
        _nest(S.EMPTYING, [S.DOOR_OPEN, S.VACUUM_ON,
                           _leaf(S.WAIT_EMPTY, **_timed(WAIT_EMPTY_MAX_S)),
                           S.VACUUM_OFF, S.DOOR_CLOSE],
              on_enter="stop_motors", **_timed(EMPTYING_TIMEOUT_S)),
        _leaf(S.STANDBY, on_enter="stop_motors"),
        _leaf(S.UNDOCK, **_timed(UNDOCK_TIMEOUT_S)),
    ]


def _t(trigger: str, source: str | list[str], dest: str, **extra: Any) -> dict[str, Any]:
    return {"trigger": trigger, "source": source, "dest": dest, **extra}


def _failure(trigger: str, source: str | list[str], retry_dest: str) -> list[dict[str, Any]]:
    """Section 4 for one error: retry under 3, else fall back, else ``recovery``."""
    return [
        _t(trigger, source, retry_dest, prepare="count_dock_failure",
           conditions="may_retry_docking"),
        _t(trigger, source, FALLBACK_STATE, conditions="may_fall_back", after="fell_back"),
        _t(trigger, source, RootState.RECOVERY, after="gave_up_docking"),
    ]


def _approach_case(turn: str, forward: str, entry: str, overlap: str) -> list[dict[str, Any]]:
    """A side approach: turn across the beams, drive, meet the front beam, reach the overlap."""
    return [
        _t(T.TURNED, turn, forward),
        _t(T.FRONT_BEAM_ENTERED, forward, entry),
        _t(T.TURNED, entry, overlap),
        _t(T.OVERLAP_REACHED, overlap, S.APPROACH),
    ]


DOCKING_TRANSITIONS: list[dict[str, Any]] = [
    # Section 1, phase 1: search.
    _t(T.BEAM_DETECTED, S.WALL_FOLLOW, S.FORCE_FIELD_DETECT),
    _t(T.FIELD_LOST, S.FORCE_FIELD_DETECT, S.WALL_FOLLOW),
    _t(T.FIELD_DETECTED, S.FORCE_FIELD_DETECT, S.DIRECTION_TURN),
    _t(T.DIRECTION_FOUND, S.DIRECTION_TURN, S.POSITION),
    _t(T.FIELD_LOST, S.DIRECTION_TURN, S.WALL_FOLLOW),
    # Section 2: scan the beams, then the case they call for.
    _t(T.FAR_RIGHT_SEEN, S.SCAN_BEAMS, S.LEFT_APPROACH),
    _t(T.FAR_LEFT_SEEN, S.SCAN_BEAMS, S.RIGHT_APPROACH),
    _t(T.FRONT_SEEN, S.SCAN_BEAMS, S.FRONT_APPROACH),
    _t(T.REAR_SEEN, S.SCAN_BEAMS, S.REAR_APPROACH),
    *_approach_case(S.TURN_LEFT, S.FORWARD_L, S.FRONT_R_ENTRY, S.OVERLAP_L),
    *_approach_case(S.TURN_RIGHT, S.FORWARD_R, S.FRONT_L_ENTRY, S.OVERLAP_R),
    _t(T.SKEW_LEFT, S.CHECK_SKEW, S.SKEW_LEFT),
    _t(T.SKEW_RIGHT, S.CHECK_SKEW, S.SKEW_RIGHT),
    _t(T.CORRECT, S.SKEW_LEFT, S.CORRECT_RIGHT),
    _t(T.CORRECT, S.SKEW_RIGHT, S.CORRECT_LEFT),
    _t(T.CORRECTED, [S.CORRECT_RIGHT, S.CORRECT_LEFT], S.CHECK_SKEW),
    _t(T.CENTERED, S.CHECK_SKEW, S.CENTERED),
    _t(T.OVERLAP_REACHED, S.CENTERED, S.APPROACH),
    # Rear docking is refused: turn round, then the front case.
    _t(T.TURNED, S.TURN180, S.FRONT_NOW),
    _t(T.FRONT_READY, S.FRONT_NOW, S.FRONT_APPROACH),
    # Section 1, phase 2: approach on the front beams.
    _t(T.FRONT_LEFT_ONLY, S.FRONT_BEAM_DETECT, S.LEFT_ONLY),
    _t(T.FRONT_RIGHT_ONLY, S.FRONT_BEAM_DETECT, S.RIGHT_ONLY),
    _t(T.MICRO_TURN, S.LEFT_ONLY, S.MICRO_RIGHT),
    _t(T.MICRO_TURN, S.RIGHT_ONLY, S.MICRO_LEFT),
    _t(T.TURNED, [S.MICRO_RIGHT, S.MICRO_LEFT], S.FRONT_BEAM_DETECT),
    _t(T.FRONT_BOTH, S.FRONT_BEAM_DETECT, S.BOTH_BEAMS),
    _t(T.IN_OVERLAP, S.BOTH_BEAMS, S.OVERLAP_ZONE),
    _t(T.APPROACHED, S.OVERLAP_ZONE, S.ALIGN),
    # Phase 3: align.
    _t(T.CENTER_FOUND, S.CENTER_BEAM_SEARCH, S.FINE_ALIGN),
    _t(T.COMPARE, S.FINE_ALIGN, S.SIGNAL_COMPARE),
    _t(T.LEFT_STRONGER, S.SIGNAL_COMPARE, S.LEFT_STRONGER),
    _t(T.RIGHT_STRONGER, S.SIGNAL_COMPARE, S.RIGHT_STRONGER),
    _t(T.ADJUST, S.LEFT_STRONGER, S.MICRO_ADJUST_R),
    _t(T.ADJUST, S.RIGHT_STRONGER, S.MICRO_ADJUST_L),
    _t(T.ADJUSTED, [S.MICRO_ADJUST_R, S.MICRO_ADJUST_L], S.SIGNAL_COMPARE),
    _t(T.BALANCED, S.SIGNAL_COMPARE, S.BALANCED),
    _t(T.ALIGNED, S.BALANCED, S.DOCK),
    # Phase 4: dock.
    _t(T.TOUCHED, S.SLOW_FORWARD, S.CONTACT_CHECK),
    _t(T.CONTACT_MADE, S.CONTACT_CHECK, S.VOLTAGE_DETECT),
    _t(T.NO_CONTACT, S.CONTACT_CHECK, S.ALIGN_CHECK),
    _t(T.ALIGNMENT_OK, S.ALIGN_CHECK, S.SLOW_FORWARD),
    _t(T.VOLTAGE_OK, S.VOLTAGE_DETECT, S.MOTOR_STOP),
    _t(T.STOPPED, S.MOTOR_STOP, S.CHARGING, after="dock_succeeded"),
    _t(T.BACKED_OFF, S.RETRY, S.ALIGN),
    # Section 4: errors, retries, fallback, and the end of the seed's endless loop.
    *_failure(T.ALIGN_LOST, [S.SLOW_FORWARD, S.ALIGN_CHECK], S.ALIGN),
    *_failure(T.CONTACT_FAILED, [S.SLOW_FORWARD, S.CONTACT_CHECK, S.ALIGN_CHECK], S.RETRY),
    *_failure(T.VOLTAGE_ABNORMAL, S.VOLTAGE_DETECT, S.RETRY),
    *_failure(T.SIGNAL_LOST, STEPS, S.SEARCH),
    *_failure(CoreTrigger.TIMEOUT, [*STEPS, S.SEARCH], S.SEARCH),
    _t(T.DOCK_IR_LOST, [S.DOCKING], RootState.RECOVERY, after="gave_up_docking"),
    # Section 5: charge, empty the bin, wait, undock, clean again.
    _t(T.BIN_FULL, S.CHARGING, S.EMPTYING),
    _t(T.DOOR_OPENED, S.DOOR_OPEN, S.VACUUM_ON),
    _t(T.SUCTION_ON, S.VACUUM_ON, S.WAIT_EMPTY),
    _t(T.BIN_EMPTIED, S.WAIT_EMPTY, S.VACUUM_OFF),
    _t(CoreTrigger.TIMEOUT, S.WAIT_EMPTY, S.VACUUM_OFF),
    _t(T.SUCTION_OFF, S.VACUUM_OFF, S.DOOR_CLOSE),
    _t(T.DOOR_CLOSED, S.DOOR_CLOSE, S.CHARGING),
    _t(CoreTrigger.TIMEOUT, S.EMPTYING, S.CHARGING),
    _t(T.CHARGED, S.CHARGING, S.STANDBY),
    _t(T.CONTACTS_LOST, [S.CHARGING, S.STANDBY], S.DOCKING),
    _t(T.CLEAN_SCHEDULED, S.STANDBY, S.UNDOCK),
    _t(T.UNDOCKED, S.UNDOCK, RootState.MISSION),
    _t(CoreTrigger.TIMEOUT, S.UNDOCK, RootState.RECOVERY),
    # After a restart on the dock: carry on charging.
    _t(T.RESUME_CHARGING, RootState.IDLE, S.CHARGING),
    # Below the battery threshold (or told to): from wherever the robot is, to the dock.
    _t(T.GO_DOCK, [RootState.IDLE, RootState.MISSION, RootState.RELOCATE, RootState.RECOVERY],
       S.DOCKING),
]
"""Every docking transition; a profile that docks plugs them in (``machine_part``)."""
