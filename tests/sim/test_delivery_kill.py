"""SIGKILL of RelayBot's daemon while the parcel is in the box, then a restart (issue 17);
and the end of the error table: home unreachable 3 times, estop."""

from __future__ import annotations

import pytest
from delivery_harness import SCENARIOS, kinds, moves, run_mission


def killed_while_loaded(when_state: str, delay_s: float) -> str:
    """The ``delivery`` scenario with ``robot.kill`` ``delay_s`` into ``when_state``; the
    daemon restarts 2 s later (same state directory, a new process as far as it knows)."""
    text = (SCENARIOS / "delivery.toml").read_text()
    text = text.replace('[success]', f'''[[script]]
at_s = 5.5
when_state = "{when_state}"
delay_s = {delay_s}
action = "robot.kill"
duration_s = 2.0

[success]''', 1)
    return text


@pytest.mark.parametrize(("when_state", "delay_s"), [
    ("mission.returning_to_customer", 6.0),
    pytest.param("mission.delivering", 4.0, marks=pytest.mark.slow),
])
def test_a_killed_daemon_knows_the_parcel_it_holds(when_state: str, delay_s: float) -> None:
    """Killed with order 7's parcel in the box: the restarted daemon restores order 7,
    the customer's position and the parcel (and its pose) from the state store, resumes the
    delivery (``resume_delivery`` → returning_to_customer), hands it over and goes home."""
    result = run_mission(killed_while_loaded(when_state, delay_s))
    events = result.events
    kill = next(e for e in events if e.get("action") == "robot.kill")
    restored = [e for e in kinds(events, "persist.restored")
                if e["key"] == "delivery.mission" and e["t"] > kill["t"]]
    assert restored, "the restarted daemon restored nothing"
    values = restored[0]["values"]
    assert values["order_id"] == 7
    assert values["parcel_in_box"] is True
    assert values["customer_x_m"] is not None
    resumed = [e for e in kinds(events, "delivery.resumed") if e["t"] > kill["t"]]
    assert resumed and resumed[0]["order_id"] == 7 and resumed[0]["parcel_in_box"] is True
    assert ("mission.waiting", "resume_delivery", "mission.returning_to_customer") in moves(
        events)
    assert [e["order_id"] for e in kinds(events, "delivery.delivered")] == [7]
    # Killed mid hand-over, the box opens once more and that stay in delivering was cut short:
    # the scenario's own box and duration checks do not apply to such a run.
    cut = ("box opened 3 time(s)", "mission.delivering lasted")
    left = [r for r in result.reasons if not (when_state == "mission.delivering"
                                              and r.startswith(cut))]
    assert left == [], result.reasons


def test_home_unreachable_three_times_is_an_estop() -> None:
    """The LiDAR unplugged for good on the way to the warehouse: 30 s on odometry, then
    error_recovery; each of its 3 home attempts waits 30 s for the scans in vain, then the
    root estop (latched, manual intervention), as the seed's recovery step 7 says."""
    from delivery_harness import ORDER_7, mission_text, person

    result = run_mission(mission_text(
        people=person("customer", 1.4, 1.0, ORDER_7),
        script=('[[script]]\nat_s = 0.0\nwhen_state = "mission.navigating_to_warehouse"\n'
                'delay_s = 3.0\naction = "lidar.unplug"\n'),
        success=('time_limit_s = 300\nfinal_state = "estop"\nno_collisions = true\n'
                 'no_estop = false')))
    assert result.reasons == []
    assert ("mission.navigating_to_warehouse", "navigation_error",
            "mission.error_recovery") in moves(result.events)
    assert ("mission.error_recovery", "recovery_failed", "estop") in moves(result.events)
    attempts = kinds(result.events, "delivery.recovery_attempt")
    assert [a["attempt"] for a in attempts] == [1, 2, 3]
    assert [e["category"] for e in kinds(result.events, "delivery.recovery")] == ["lidar_lost"]
