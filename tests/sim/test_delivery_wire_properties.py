"""RelayBot's properties 12, 19 and 22 on what a whole mission really did (the real daemon,
profile and drivers on the simulator's devices), not on the tables that say what it should do:

- 12: the daemon's transition log (every transition it records: old state, new state,
  trigger, time) is whole: each entry starts where the one before ended, in time order, and
  the states the robot was in (the simulator samples them) are the log's.
- 19: the LED command for each state reaches the motor board (``mcu.led``: the words the fake
  board acknowledged on the serial line), after the transition and before the next one.
- 22: the real ``mission.delivering`` lasts exactly 10 s of loop time, wherever the customer
  and whenever the loading is confirmed (a few derandomized missions)."""

from __future__ import annotations

import itertools
import math
from typing import Any

import pytest
from delivery_harness import ORDER_7, kinds, mission_text, person, run_mission
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from behaviours.profiles.delivery.states import STATE_LEDS
from sim.runner import SimResult

QUICK = "\n[config.delivery]\nwarehouse_x_m = 1.5\nwarehouse_y_m = -1.2\n"


def mission(confirm_after_s: float = 1.0, customer: tuple[float, float] = (1.4, 1.0)
            ) -> SimResult:
    """A customer walks in, order 7, loading confirmed ``confirm_after_s`` after arrival,
    the hand-over, home."""
    cx, cy = customer
    script = ('[[script]]\nat_s = 2.0\naction = "person.walk"\nname = "customer"\n'
              f"points = [[0.0, 3.4], [{cx:.3f}, {cy:.3f}]]\nspeed_mps = 1.0\n\n"
              '[[script]]\nat_s = 2.2\nwhen_state = "mission.loading"\n'
              f'delay_s = {confirm_after_s:.3f}\naction = "staff.confirm_loaded"\n\n'
              '[[script]]\nat_s = 3.0\nwhen_state = "mission.resetting"\n'
              'action = "person.walk"\nname = "customer"\n'
              "points = [[0.0, 3.4], [-1.6, 3.4]]\nspeed_mps = 1.0\n")
    return run_mission(mission_text(
        config=QUICK, people=person("customer", -1.6, 3.4, ORDER_7), script=script,
        success=('time_limit_s = 200\nfinal_state = "mission.waiting"\n'
                 'states_reached = ["mission.delivering", "mission.resetting"]\n'
                 "no_estop = true")))


@pytest.fixture(scope="module")
def run() -> SimResult:
    result = mission()
    assert result.reasons == []
    return result


def _log(events: list[dict[str, Any]]) -> list[dict[str, Any]]:
    return [e for e in events if e["kind"] == "transition"]


# Feature: relaybot-autonomous-delivery, Property 12: For any state transition, a log entry should
# be created containing old state, new state, and timestamp.
def test_property_12_the_daemon_s_transition_log_is_whole(run: SimResult) -> None:
    log = _log(run.events)
    assert log[0]["src"] == "boot"
    for before, after in itertools.pairwise(log):
        assert after["src"] == before["dst"], (before, after)
        assert after["t"] >= before["t"]
    for entry in log:
        assert {"src", "dst", "trigger", "t"} <= set(entry) and entry["src"] != entry["dst"]
    # Each state the simulator saw the robot in, sampled at 10 Hz, is the log's at that time.
    times = [e["t"] for e in log]
    for point in run.tracks["sim-1"]:
        i = max((k for k, t in enumerate(times) if t <= point.t_s), default=None)
        if i is not None and (i + 1 == len(times) or times[i + 1] > point.t_s + 1e-9):
            assert point.state == log[i]["dst"]
    assert {"mission.delivering", "mission.resetting"} <= {e["dst"] for e in log}


# Feature: relaybot-autonomous-delivery, Property 19: For any state transition, the appropriate
# LED command should be sent to Arduino (WAITING→idle, APPROACHING→moving, LOADING→waiting, etc.).
def test_property_19_each_state_s_led_reaches_the_board(run: SimResult) -> None:
    events = run.events
    log = [e for e in _log(events) if e["dst"].startswith("mission.")]
    words = [(e["t"], e["word"]) for e in kinds(events, "mcu.led")]
    assert words, "no LED command reached the board"
    for entry, nxt in zip(log, [*log[1:], None], strict=False):
        state = entry["dst"].removeprefix("mission.")
        if state not in STATE_LEDS:
            continue
        end = math.inf if nxt is None else nxt["t"]
        between = [w for t, w in words if entry["t"] <= t <= end]
        assert between and between[-1] == STATE_LEDS[state].value, (state, between)


# Feature: relaybot-autonomous-delivery, Property 22: For any delivery in DELIVERING state, the
# state should remain DELIVERING for exactly 10 seconds before transitioning to RESETTING.
@settings(max_examples=3, deadline=None, derandomize=True, phases=(Phase.generate,),
          suppress_health_check=[HealthCheck.too_slow])
@given(st.floats(0.5, 8.0), st.floats(0.6, 1.6), st.floats(0.4, 1.4))
def test_property_22_the_real_hand_over_lasts_10_s(confirm_after_s: float, cx: float,
                                                   cy: float) -> None:
    result = mission(confirm_after_s, (cx, cy))
    assert result.reasons == []
    log = _log(result.events)
    into = [e for e in log if e["dst"] == "mission.delivering"]
    assert len(into) == 1
    out = next(e for e in log if e["src"] == "mission.delivering")
    assert out["dst"] == "mission.resetting" and out["trigger"] == "delivery_complete"
    assert out["t"] - into[0]["t"] == pytest.approx(10.0, abs=1e-6)
