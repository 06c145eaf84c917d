"""RelayBot's whole-mission properties (seed 1, 2, 3, 4, 13) on the real daemon, profile,
navigation stack and drivers, with the simulator's devices underneath (LD19 packets, motor
board frames, camera pixels), in virtual time.

A mission run costs 0.5-5 s of wall time (the MCL filter and the planner at 20 Hz, the QR
decoder on rendered frames), so the missions are kept short (starts and customers near home)
and each property draws 20 of them per run, derandomized (the same 20 every CI run: a failure
is reproducible), not the seed's 100, with ``deadline=None``; the properties of the table,
the parser, the database and the outputs run 100+ examples each beside the profile's code
(``tests/behaviours/profiles/delivery``)."""

from __future__ import annotations

import math

import pytest
from delivery_harness import ORDER_7, kinds, mission_text, moves, person, run_mission
from hypothesis import HealthCheck, Phase, assume, given, settings
from hypothesis import strategies as st

MISSION = settings(max_examples=20, deadline=None, derandomize=True, phases=(Phase.generate,),
                   suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
"""A few missions each; no shrinking (a failing mission re-run dozens of times takes
minutes: the example and its events are in the failure as they are)."""
ZONE_RADIUS_M = 3.0


def on_floor(x_m: float, y_m: float) -> bool:
    """Free floor of the test shop, 0.3 m from its walls and boxes."""
    return (-1.7 <= x_m <= 3.1 and -1.7 <= y_m <= 3.6
            and not (x_m < -0.3 and y_m > 3.6))


@st.composite
def zone_spot(draw: st.DrawFn, r_min: float = 0.9, r_max: float = 2.8
              ) -> tuple[float, float]:
    r = draw(st.floats(r_min, r_max))
    a = draw(st.floats(-math.pi, math.pi))
    x, y = r * math.cos(a), r * math.sin(a)
    assume(on_floor(x, y))
    return x, y


# Feature: relaybot-autonomous-delivery, Property 1: For any delivery cycle completion or system
# startup, the robot should navigate to and stop at coordinates (0,0) within 10cm tolerance.
@MISSION
@given(st.floats(-1.5, 1.5), st.floats(-1.5, 1.5), st.floats(-180, 180))
def test_property_1_home_at_startup(x_m: float, y_m: float, heading_deg: float) -> None:
    """Started anywhere on the shop floor within 1.5 m of home (localised there; farther
    starts only take longer), the robot drives to (0, 0) and stops within 10 cm, true
    position, before it watches the zone."""
    assume(on_floor(x_m, y_m) and math.hypot(x_m, y_m) > 0.3)
    result = run_mission(mission_text(
        start=(x_m, y_m, heading_deg),
        success=f"time_limit_s = {15 + 12 * math.hypot(x_m, y_m):.0f}\n"
                "final_poses = [ { x_m = 0.0, y_m = 0.0, tolerance_m = 0.10 } ]\n"
                "no_collisions = true\nno_estop = true"))
    assert result.reasons == []
    assert kinds(result.events, "delivery.at_home")


# Feature: relaybot-autonomous-delivery, Property 2: For any person detected in the delivery
# zone while in WAITING state, the state machine should transition to APPROACHING state.
@MISSION
@given(zone_spot(0.9, 4.2))
def test_property_2_a_person_in_the_zone_is_approached(spot: tuple[float, float]) -> None:
    """A person standing inside the 3 m zone is detected (at its position, property 25) and
    approached; one standing outside it is not."""
    x_m, y_m = spot
    r = math.hypot(x_m, y_m)
    assume(abs(r - ZONE_RADIUS_M) > 0.2)
    result = run_mission(mission_text(
        people=person("customer", x_m, y_m),
        success='time_limit_s = 3\nfinal_state = "mission.approaching"'))
    approached = ("mission.waiting", "person_detected", "mission.approaching") in moves(
        result.events)
    assert approached is (r < ZONE_RADIUS_M)
    if approached:
        seen = kinds(result.events, "delivery.person_detected")[0]
        assert math.hypot(seen["map_x_m"] - x_m, seen["map_y_m"] - y_m) < 0.2


# Feature: relaybot-autonomous-delivery, Property 3: For any customer tracking loss during
# APPROACHING state, the robot should stop movement and transition back to WAITING state.
@MISSION
@given(zone_spot(1.5, 2.6), st.floats(0.5, 3.0))
def test_property_3_a_customer_who_leaves_is_given_up(spot: tuple[float, float],
                                                      after_s: float) -> None:
    """The customer walks out of the zone while the robot drives up: ``person_lost``, back to
    waiting, and the robot returns home (it stopped, then went back)."""
    x_m, y_m = spot
    away = (3.6 * math.cos(math.atan2(y_m, x_m)), 3.6 * math.sin(math.atan2(y_m, x_m)))
    assume(-1.9 < away[0] < 3.3 and -1.9 < away[1] < 3.8)
    result = run_mission(mission_text(
        people=person("customer", x_m, y_m),
        script=(f'[[script]]\nat_s = 0.0\nwhen_state = "mission.approaching"\n'
                f'delay_s = {after_s:.2f}\naction = "person.walk"\nname = "customer"\n'
                f"points = [[{away[0]:.3f}, {away[1]:.3f}]]\nspeed_mps = 1.2\n\n"
                '[[script]]\nat_s = 1.0\nwhen_state = "mission.waiting"\ndelay_s = 12.0\n'
                'action = "person.stop"\nname = "customer"\n'),
        success=('time_limit_s = 40\nfinal_state = "mission.waiting"\n'
                 'states_reached = ["mission.approaching"]\n'
                 "final_poses = [ { x_m = 0.0, y_m = 0.0, tolerance_m = 0.10 } ]\n"
                 "no_collisions = true")))
    assert ("mission.approaching", "person_lost", "mission.waiting") in moves(result.events)
    assert "mission.verifying" not in [m[2] for m in moves(result.events)]
    assert result.reasons == []


# Feature: relaybot-autonomous-delivery, Property 4: For any approach to customer, when distance
# becomes less than 50cm, the state machine should stop and transition to VERIFYING state.
@MISSION
@given(zone_spot(0.9, 2.2))
def test_property_4_close_to_the_customer_verifying_starts(spot: tuple[float, float]) -> None:
    """Driving up to a customer standing anywhere in the zone, the robot stops with less than
    50 cm between them (never touching) and asks for the QR code (verifying)."""
    x_m, y_m = spot
    result = run_mission(mission_text(
        people=person("customer", x_m, y_m),
        success=('time_limit_s = 60\nfinal_state = "mission.verifying"\n'
                 'states_reached = ["mission.verifying"]\nno_collisions = true')))
    assert result.reasons == []
    reached = kinds(result.events, "delivery.reached_customer")[0]
    assert 0.0 < reached["gap_m"] < 0.5
    truth = math.hypot(reached["x_m"] - x_m, reached["y_m"] - y_m)
    assert truth - 0.38 < 0.5  # the true gap too (footprints 0.18 m and 0.2 m)


NON_RECOVERY = ["waiting", "approaching", "verifying", "navigating_to_warehouse", "loading",
                "returning_to_customer", "delivering", "resetting"]
QUICK = "\n[config.delivery]\nwarehouse_x_m = 1.5\nwarehouse_y_m = -1.2\n"
"""A warehouse near home: a whole mission in about 80 s of virtual time."""


def error_script(state: str, after_s: float) -> str:
    """The customer walks in at 2 s; staff confirm loading (when the error comes after it);
    ``robotctl trigger error`` ``after_s`` into ``state``; the customer leaves during the
    recovery (or would be served again). Script steps run one after the other."""
    steps = ['at_s = 2.0\naction = "person.walk"\nname = "customer"\n'
             "points = [[0.0, 3.4], [1.4, 1.0]]\nspeed_mps = 1.0\n"]
    if NON_RECOVERY.index(state) > NON_RECOVERY.index("loading"):
        steps.append('at_s = 2.2\nwhen_state = "mission.loading"\ndelay_s = 1.0\n'
                     'action = "staff.confirm_loaded"\n')
    steps.append(f'at_s = 2.5\nwhen_state = "mission.{state}"\ndelay_s = {after_s:.2f}\n'
                 'action = "robotctl.trigger"\nname = "error"\n')
    steps.append('at_s = 3.0\nwhen_state = "mission.error_recovery"\naction = "person.walk"\n'
                 'name = "customer"\npoints = [[0.0, 3.4], [-1.6, 3.4]]\nspeed_mps = 1.0\n')
    return "".join(f"[[script]]\n{step}\n" for step in steps)


# Feature: relaybot-autonomous-delivery, Property 13: For any error condition in any state, the
# error handler should navigate the robot back to home position (0,0) and transition to WAITING
# state.
@pytest.mark.parametrize("state", NON_RECOVERY)
@settings(max_examples=1, deadline=None, phases=(Phase.generate,),
          suppress_health_check=[HealthCheck.too_slow])
@given(st.floats(0.1, 1.5))
def test_property_13_an_error_anywhere_ends_at_home_waiting(state: str, after_s: float) -> None:
    """An error (``robotctl trigger error``) in each of the eight states, at a random moment
    in it (verifying: the customer shows no code, so it lasts): error_recovery (box closed,
    failureScan), home within 10 cm, waiting; no estop.
    One example per state: a mission is ~5 s of wall time."""
    result = run_mission(mission_text(
        config=QUICK,
        people=person("customer", -1.6, 3.4, None if state == "verifying" else ORDER_7),
        script=error_script(state, after_s),
        success=('time_limit_s = 250\nfinal_state = "mission.waiting"\n'
                 'states_reached = ["mission.error_recovery"]\nno_estop = true\n'
                 "final_poses = [ { x_m = 0.0, y_m = 0.0, tolerance_m = 0.10 } ]")))
    assert result.reasons == []
    into = [m for m in moves(result.events) if m[2] == "mission.error_recovery"]
    assert into and into[0][0] == f"mission.{state}"
    assert ("mission.error_recovery", "recovery_complete", "mission.waiting") in moves(
        result.events)
    sounds = [e["sound"] for e in kinds(result.events, "delivery.sound")]
    assert "failureScan" in sounds
