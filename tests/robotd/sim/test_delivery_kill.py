"""SIGKILL of RelayBot's daemon while the parcel is in the box, then a restart (issue 17)."""

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
