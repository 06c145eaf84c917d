"""RelayBot's error table in whole missions (seed relaybot-delivery-design.md, "Error
Handling"): a serial timeout and a motor failure reach error_recovery with their categories;
a verifying timeout, and a navigation error from approaching, returning and resetting, each
happen in a run (the robot snagged: ``body.snag``). The navigation rows on the way to the
warehouse (obstacle, stuck, alternate path) are ``delivery-stuck`` (test_sim_delivery.py)."""

from __future__ import annotations

from typing import Any

import pytest
from delivery_harness import ORDER_7, kinds, mission_text, moves, person, run_mission

QUICK = "\n[config.delivery]\nwarehouse_x_m = 1.5\nwarehouse_y_m = -1.2\n"
"""A warehouse near home: a whole mission in about 80 s of virtual time."""


def _steps(*steps: str) -> str:
    return "".join(f"[[script]]\n{step}\n" for step in steps)


WALK_IN = ('at_s = 2.0\naction = "person.walk"\nname = "customer"\n'
           "points = [[0.0, 3.4], [1.4, 1.0]]\nspeed_mps = 1.0\n")
CONFIRM = ('at_s = 2.2\nwhen_state = "mission.loading"\ndelay_s = 1.0\n'
           'action = "staff.confirm_loaded"\n')
LEAVE = ('at_s = 3.0\nwhen_state = "mission.error_recovery"\naction = "person.walk"\n'
         'name = "customer"\npoints = [[0.0, 3.4], [-1.6, 3.4]]\nspeed_mps = 1.0\n')
HOME_WAITING = ('final_state = "mission.waiting"\nstates_reached = ["mission.error_recovery"]\n'
                "no_estop = true\nfinal_poses = [ { x_m = 0.0, y_m = 0.0, tolerance_m = 0.10 } ]")


def _run(*steps: str, qr: str | None = ORDER_7, config: str = QUICK,
         success: str = HOME_WAITING, limit_s: int = 300) -> list[dict[str, Any]]:
    result = run_mission(mission_text(
        config=config, people=person("customer", -1.6, 3.4, qr), script=_steps(*steps),
        success=f"time_limit_s = {limit_s}\n{success}"))
    assert result.reasons == []
    return result.events


def _recovered_from(events: list[dict[str, Any]]) -> tuple[str, str, str | None]:
    into = next(m for m in moves(events) if m[2] == "mission.error_recovery")
    category = kinds(events, "delivery.recovery")[0]["category"]
    return into[0], into[1], category


@pytest.mark.parametrize(("fault", "category"), [
    # The motor board's cable out for 16 s on the way to the warehouse: commands unanswered.
    (('at_s = 2.5\nwhen_state = "mission.navigating_to_warehouse"\ndelay_s = 1.0\n'
      'action = "mcu.unplug"\nduration_s = 16.0\n',), "serial_timeout"),
    # The wheels do not turn (no encoder ticks, no motion) though the board answers.
    (('at_s = 2.5\nwhen_state = "mission.navigating_to_warehouse"\ndelay_s = 1.0\n'
      'action = "encoders.fail"\nduration_s = 25.0\n',
      'at_s = 2.6\naction = "body.snag"\nduration_s = 24.0\n'), "motor"),
])
def test_serial_timeout_and_motor_failure_reach_error_recovery(fault: tuple[str, ...],
                                                               category: str) -> None:
    events = _run(WALK_IN, *fault, LEAVE)
    assert _recovered_from(events) == ("mission.navigating_to_warehouse", "navigation_error",
                                       category)
    assert ("mission.error_recovery", "recovery_complete", "mission.waiting") in moves(events)
    assert not kinds(events, "delivery.stuck")  # not the planner's to work round


def test_a_verifying_timeout_goes_back_to_waiting() -> None:
    """The customer shows no code: the (configured, shorter) timeout ends verifying."""
    events = _run(WALK_IN, qr=None, config=QUICK + "verifying_timeout_s = 6.0\n",
                  success='final_state = "mission.waiting"\n'
                          'states_reached = ["mission.verifying"]\nno_estop = true',
                  limit_s=80)
    assert ("mission.verifying", "timeout", "mission.waiting") in moves(events)
    stays = [e["t"] for e in events if e["kind"] == "transition"
             and e["dst"] == "mission.verifying"]
    left = next(e["t"] for e in events if e["kind"] == "transition"
                and e["src"] == "mission.verifying")
    assert left - stays[0] == pytest.approx(6.0, abs=0.01)


@pytest.mark.parametrize(("state", "snag_s"), [
    ("approaching", 40.0),
    ("returning_to_customer", 70.0),
    ("resetting", 70.0),
])
def test_a_navigation_error_from_each_navigating_state(state: str, snag_s: float) -> None:
    """The robot snagged in ``state``: the approach gives up after its standoffs, the others
    after 30 s stuck and an alternate path; navigation_error, error_recovery, home once the
    snag lets go."""
    # The steps run in turn; approached, the customer stops 2.6 m away (walking up to the
    # robot, they would reach it themselves).
    first = (WALK_IN, CONFIRM) if state != "approaching" else (
        'at_s = 2.0\naction = "person.walk"\nname = "customer"\n'
        "points = [[0.0, 3.4], [0.0, 2.6]]\nspeed_mps = 1.0\n",)
    events = _run(*first,
                  f'at_s = 2.5\nwhen_state = "mission.{state}"\ndelay_s = 0.5\n'
                  f'action = "body.snag"\nduration_s = {snag_s}\n', LEAVE)
    src, trigger, category = _recovered_from(events)
    assert (src, trigger) == (f"mission.{state}", "navigation_error")
    assert category == "stuck"
    if state != "approaching":
        assert kinds(events, "delivery.alternate_path")


def test_the_box_does_not_close_on_a_hand() -> None:
    """A hand in the box opening when the 10 s are up (the front IR sensor under
    delivery.hand_cm): the hand-over waits until it has gone, then the box closes."""
    hand = '    { name = "hand", x_m = -1.9, y_m = -1.9, present = false, legs = false, ' \
           'radius_m = 0.03 },\n'
    result = run_mission(mission_text(
        config=QUICK, people=person("customer", -1.6, 3.4, ORDER_7) + hand,
        script=_steps(WALK_IN, CONFIRM,
                      'at_s = 2.5\nwhen_state = "mission.delivering"\ndelay_s = 8.0\n'
                      'action = "person.step_in"\nname = "hand"\nduration_s = 4.0\n'),
        success=('time_limit_s = 200\nfinal_state = "mission.waiting"\n'
                 'states_reached = ["mission.resetting"]\nno_estop = true'))
        # a front IR sensor that reads under 15 cm (the default's floor is 20)
        .replace("\nheading_deg = 0.00\n", "\nheading_deg = 0.00\nbody = { range_min_cm = 4.0 }\n",
                 1))
    assert result.reasons == []
    log = [e for e in result.events if e["kind"] == "transition"]
    into = next(e["t"] for e in log if e["dst"] == "mission.delivering")
    out = next(e for e in log if e["src"] == "mission.delivering")
    waited = kinds(result.events, "delivery.hand_in_box")[0]
    assert waited["gone"] is True and waited["closest_cm"] < 15
    # The hand was there from 8 s to 12 s: the hand-over ends 0.5 s after it went.
    assert out["trigger"] == "delivery_complete"
    assert out["t"] - into == pytest.approx(12.5, abs=0.2)
    boxes = [(e["t"], e["angle_deg"]) for e in kinds(result.events, "delivery.box")]
    closed = next(t for t, angle in boxes if angle == 0 and t > into)
    assert closed >= into + 12.0


def test_a_failed_plan_is_retried_after_2_s_with_relaxed_constraints() -> None:
    """The warehouse spot 0.27 m below the shelves' end: no path with the planner's 0.30 m
    clearance (the goal in collision); logged, 2 s, planned again with 0.20 m: reached."""
    config = "\n[config.delivery]\nwarehouse_x_m = 3.6\nwarehouse_y_m = 0.33\n"
    result = run_mission(mission_text(
        config=config, people=person("customer", -1.6, 3.4, ORDER_7), script=_steps(WALK_IN),
        success='time_limit_s = 120\nfinal_state = "mission.loading"\nno_estop = true'))
    assert result.reasons == []
    failed = kinds(result.events, "delivery.no_path")[0]
    retried = kinds(result.events, "delivery.relaxed_plan")[0]
    assert "collision" in failed["detail"] and failed["relaxed_clearance_m"] == 0.2
    assert retried["reason"] == "reached"
    assert retried["t"] - failed["t"] >= 2.0
    assert ("mission.navigating_to_warehouse", "reached_warehouse",
            "mission.loading") in moves(result.events)
