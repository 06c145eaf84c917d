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

from typing import Any

SEARCH_TIMEOUT_S = 180.0
STEP_TIMEOUT_S = 60.0
"""position, approach, align, dock: each must finish within this (a failure 903/905)."""
EMPTYING_TIMEOUT_S = 90.0
WAIT_EMPTY_MAX_S = 30.0
"""The seed's 10-30 s: ``wait_empty`` ends at the latest after this."""
UNDOCK_TIMEOUT_S = 30.0

FALLBACK_STATE = "docking.search"
"""Wall following again: ``search`` is entered anew (its timeout restarts) at ``wall_follow``."""
STEPS = ["docking.position", "docking.approach", "docking.align", "docking.dock"]


def _nest(name: str, children: list[Any], **extra: Any) -> dict[str, Any]:
    first = children[0]
    return {"name": name, "children": children,
            "initial": first if isinstance(first, str) else first["name"], **extra}


def _timed(timeout_s: float) -> dict[str, Any]:
    return {"timeout": timeout_s, "on_timeout": "timed_out"}


def docking_states() -> list[str | dict[str, Any]]:
    """The children of ``docking``, in the seed's order."""
    return [
        # Section 1, phase 1.
        _nest("search", ["wall_follow", "force_field_detect", "direction_turn"],
              **_timed(SEARCH_TIMEOUT_S)),
        # Section 2: where the robot is decides how it comes in.
        _nest("position", [
            "scan_beams",
            _nest("left_approach", ["turn_left", "forward_l", "front_r_entry", "overlap_l"]),
            _nest("right_approach", ["turn_right", "forward_r", "front_l_entry", "overlap_r"]),
            _nest("front_approach", ["check_skew", "skew_left", "skew_right", "correct_right",
                                     "correct_left", "centered"]),
            _nest("rear_approach", ["turn180", "front_now"]),
        ], **_timed(STEP_TIMEOUT_S)),
        # Section 1, phases 2-4.
        _nest("approach", ["front_beam_detect", "left_only", "right_only", "micro_right",
                           "micro_left", "both_beams", "overlap_zone"], **_timed(STEP_TIMEOUT_S)),
        _nest("align", ["center_beam_search", "fine_align", "signal_compare", "left_stronger",
                        "right_stronger", "micro_adjust_r", "micro_adjust_l", "balanced"],
              **_timed(STEP_TIMEOUT_S)),
        _nest("dock", ["slow_forward", "contact_check", "align_check", "voltage_detect",
                       "motor_stop", "retry"], **_timed(STEP_TIMEOUT_S)),
        # Section 5: the station.
        {"name": "charging", "on_enter": "stop_motors"},
        _nest("emptying", ["door_open", "vacuum_on",
                           {"name": "wait_empty", **_timed(WAIT_EMPTY_MAX_S)},
                           "vacuum_off", "door_close"],
              on_enter="stop_motors", **_timed(EMPTYING_TIMEOUT_S)),
        {"name": "standby", "on_enter": "stop_motors"},
        {"name": "undock", **_timed(UNDOCK_TIMEOUT_S)},
    ]


def _t(trigger: str, source: str | list[str], dest: str, **extra: Any) -> dict[str, Any]:
    return {"trigger": trigger, "source": source, "dest": dest, **extra}


def _p(*parts: str) -> str:
    return ".".join(("docking", *parts))


def _failure(trigger: str, source: str | list[str], retry_dest: str) -> list[dict[str, Any]]:
    """Section 4 for one error: retry under 3, else fall back, else ``recovery``."""
    return [
        _t(trigger, source, retry_dest, prepare="count_dock_failure",
           conditions="may_retry_docking"),
        _t(trigger, source, FALLBACK_STATE, conditions="may_fall_back", after="fell_back"),
        _t(trigger, source, "recovery", after="gave_up_docking"),
    ]


def _approach_case(case: str, turn: str, forward: str, entry: str, overlap: str
                   ) -> list[dict[str, Any]]:
    """A side approach: turn across the beams, drive, meet the front beam, reach the overlap."""
    return [
        _t("turned", _p("position", case, turn), _p("position", case, forward)),
        _t("front_beam_entered", _p("position", case, forward), _p("position", case, entry)),
        _t("turned", _p("position", case, entry), _p("position", case, overlap)),
        _t("overlap_reached", _p("position", case, overlap), _p("approach")),
    ]


DOCKING_TRANSITIONS: list[dict[str, Any]] = [
    # Section 1, phase 1: search.
    _t("beam_detected", _p("search", "wall_follow"), _p("search", "force_field_detect")),
    _t("field_lost", _p("search", "force_field_detect"), _p("search", "wall_follow")),
    _t("field_detected", _p("search", "force_field_detect"), _p("search", "direction_turn")),
    _t("direction_found", _p("search", "direction_turn"), _p("position")),
    _t("field_lost", _p("search", "direction_turn"), _p("search", "wall_follow")),
    # Section 2: scan the beams, then the case they call for.
    _t("far_right_seen", _p("position", "scan_beams"), _p("position", "left_approach")),
    _t("far_left_seen", _p("position", "scan_beams"), _p("position", "right_approach")),
    _t("front_seen", _p("position", "scan_beams"), _p("position", "front_approach")),
    _t("rear_seen", _p("position", "scan_beams"), _p("position", "rear_approach")),
    *_approach_case("left_approach", "turn_left", "forward_l", "front_r_entry", "overlap_l"),
    *_approach_case("right_approach", "turn_right", "forward_r", "front_l_entry", "overlap_r"),
    _t("skew_left", _p("position", "front_approach", "check_skew"),
       _p("position", "front_approach", "skew_left")),
    _t("skew_right", _p("position", "front_approach", "check_skew"),
       _p("position", "front_approach", "skew_right")),
    _t("correct", _p("position", "front_approach", "skew_left"),
       _p("position", "front_approach", "correct_right")),
    _t("correct", _p("position", "front_approach", "skew_right"),
       _p("position", "front_approach", "correct_left")),
    _t("corrected", [_p("position", "front_approach", "correct_right"),
                     _p("position", "front_approach", "correct_left")],
       _p("position", "front_approach", "check_skew")),
    _t("centered", _p("position", "front_approach", "check_skew"),
       _p("position", "front_approach", "centered")),
    _t("overlap_reached", _p("position", "front_approach", "centered"), _p("approach")),
    # Rear docking is refused: turn round, then the front case.
    _t("turned", _p("position", "rear_approach", "turn180"),
       _p("position", "rear_approach", "front_now")),
    _t("front_ready", _p("position", "rear_approach", "front_now"),
       _p("position", "front_approach")),
    # Section 1, phase 2: approach on the front beams.
    _t("front_left_only", _p("approach", "front_beam_detect"), _p("approach", "left_only")),
    _t("front_right_only", _p("approach", "front_beam_detect"), _p("approach", "right_only")),
    _t("micro_turn", _p("approach", "left_only"), _p("approach", "micro_right")),
    _t("micro_turn", _p("approach", "right_only"), _p("approach", "micro_left")),
    _t("turned", [_p("approach", "micro_right"), _p("approach", "micro_left")],
       _p("approach", "front_beam_detect")),
    _t("front_both", _p("approach", "front_beam_detect"), _p("approach", "both_beams")),
    _t("in_overlap", _p("approach", "both_beams"), _p("approach", "overlap_zone")),
    _t("approached", _p("approach", "overlap_zone"), _p("align")),
    # Phase 3: align.
    _t("center_found", _p("align", "center_beam_search"), _p("align", "fine_align")),
    _t("compare", _p("align", "fine_align"), _p("align", "signal_compare")),
    _t("left_stronger", _p("align", "signal_compare"), _p("align", "left_stronger")),
    _t("right_stronger", _p("align", "signal_compare"), _p("align", "right_stronger")),
    _t("adjust", _p("align", "left_stronger"), _p("align", "micro_adjust_r")),
    _t("adjust", _p("align", "right_stronger"), _p("align", "micro_adjust_l")),
    _t("adjusted", [_p("align", "micro_adjust_r"), _p("align", "micro_adjust_l")],
       _p("align", "signal_compare")),
    _t("balanced", _p("align", "signal_compare"), _p("align", "balanced")),
    _t("aligned", _p("align", "balanced"), _p("dock")),
    # Phase 4: dock.
    _t("touched", _p("dock", "slow_forward"), _p("dock", "contact_check")),
    _t("contact_made", _p("dock", "contact_check"), _p("dock", "voltage_detect")),
    _t("no_contact", _p("dock", "contact_check"), _p("dock", "align_check")),
    _t("alignment_ok", _p("dock", "align_check"), _p("dock", "slow_forward")),
    _t("voltage_ok", _p("dock", "voltage_detect"), _p("dock", "motor_stop")),
    _t("stopped", _p("dock", "motor_stop"), _p("charging"), after="dock_succeeded"),
    _t("backed_off", _p("dock", "retry"), _p("align")),
    # Section 4: errors, retries, fallback, and the end of the seed's endless loop.
    *_failure("align_lost", [_p("dock", "slow_forward"), _p("dock", "align_check")],
              _p("align")),
    *_failure("contact_failed", [_p("dock", "slow_forward"), _p("dock", "contact_check"),
                                 _p("dock", "align_check")], _p("dock", "retry")),
    *_failure("voltage_abnormal", _p("dock", "voltage_detect"), _p("dock", "retry")),
    *_failure("signal_lost", STEPS, _p("search")),
    *_failure("timeout", [*STEPS, _p("search")], _p("search")),
    _t("dock_ir_lost", ["docking"], "recovery", after="gave_up_docking"),
    # Section 5: charge, empty the bin, wait, undock, clean again.
    _t("bin_full", _p("charging"), _p("emptying")),
    _t("door_opened", _p("emptying", "door_open"), _p("emptying", "vacuum_on")),
    _t("suction_on", _p("emptying", "vacuum_on"), _p("emptying", "wait_empty")),
    _t("bin_emptied", _p("emptying", "wait_empty"), _p("emptying", "vacuum_off")),
    _t("timeout", _p("emptying", "wait_empty"), _p("emptying", "vacuum_off")),
    _t("suction_off", _p("emptying", "vacuum_off"), _p("emptying", "door_close")),
    _t("door_closed", _p("emptying", "door_close"), _p("charging")),
    _t("timeout", _p("emptying"), _p("charging")),
    _t("charged", _p("charging"), _p("standby")),
    _t("contacts_lost", [_p("charging"), _p("standby")], "docking"),
    _t("clean_scheduled", _p("standby"), _p("undock")),
    _t("undocked", _p("undock"), "mission"),
    _t("timeout", _p("undock"), "recovery"),
    # After a restart on the dock: carry on charging.
    _t("resume_charging", "idle", _p("charging")),
    # Below the battery threshold (or told to): from wherever the robot is, to the dock.
    _t("go_dock", ["idle", "mission", "relocate", "recovery"], "docking"),
]
"""Every docking transition; a profile that docks plugs them in (``machine_part``)."""
