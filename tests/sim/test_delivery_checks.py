"""The delivery scenarios' success conditions, and the floor that has home inside it."""

from __future__ import annotations

from typing import Any

from sim.robots.delivery.checks import delivery_failures, state_stays
from sim.world.floor_plan import World


def _moved(t: float, dst: str) -> dict[str, Any]:
    return {"t": t, "kind": "transition", "dst": dst}


EVENTS: list[dict[str, Any]] = [
    _moved(0.0, "mission.waiting"),
    {"t": 1.0, "kind": "delivery.sound", "sound": "request_qr"},
    {"t": 1.5, "kind": "delivery.order_invalid", "reason": "not_json"},
    _moved(10.0, "mission.delivering"),
    {"t": 10.0, "kind": "delivery.box", "angle_deg": 90},
    {"t": 10.0, "kind": "delivery.sound", "sound": "delivery_greeting"},
    _moved(20.0, "mission.resetting"),
    {"t": 20.0, "kind": "delivery.box", "angle_deg": 0},
    {"t": 20.0, "kind": "delivery.delivered", "order_id": 7},
]


def test_conditions_that_hold_say_nothing() -> None:
    """Sounds in order, one opening, closed at the end, 10 s delivering, the lists: no reason."""
    extra = {"sounds_in_order": ["request_qr", "delivery_greeting"], "box_openings": 1,
             "box_closed": True, "state_durations": [{"state": "mission.delivering", "s": 10.0}],
             "events_in_order": ["delivery.order_invalid", "delivery.delivered"],
             "rejections": ["not_json"], "delivered": [7], "error_categories": []}
    assert delivery_failures(extra, EVENTS) == []


def test_each_broken_condition_is_one_sentence() -> None:
    """Wrong order, count, duration or list: each named."""
    extra = {"sounds_in_order": ["delivery_greeting", "request_qr"], "box_openings": 2,
             "state_durations": [{"state": "mission.delivering", "s": 9.0}],
             "rejections": [], "delivered": [8]}
    reasons = delivery_failures(extra, EVENTS)
    assert len(reasons) == 5
    assert any("not played in order" in r for r in reasons)
    assert any("box opened 1 time(s), expected 2" in r for r in reasons)
    assert any("mission.delivering lasted [10.0] s" in r for r in reasons)


def test_a_paced_run_allows_a_late_timer() -> None:
    """On the wall clock (--realtime, --speed) a 10 s hand-over may end a few tens of ms late;
    in virtual time it is exact to the millisecond."""
    extra = {"state_durations": [{"state": "mission.delivering", "s": 9.96}]}
    assert delivery_failures(extra, EVENTS, paced=True) == []
    assert len(delivery_failures(extra, EVENTS)) == 1
    far = {"state_durations": [{"state": "mission.delivering", "s": 9.5}]}
    assert len(delivery_failures(far, EVENTS, paced=True)) == 1


def test_state_stays_counts_each_stay() -> None:
    """A state entered twice has two stays; one still open at the end has none."""
    events = [_moved(0, "a"), _moved(2, "b"), _moved(5, "a"), _moved(6, "b"), _moved(9, "a")]
    assert state_stays(events, "b") == [3.0, 3.0]


def test_a_floor_can_have_its_origin_inside() -> None:
    """``x_min_m``/``y_min_m``: home (0, 0) in the middle of the shop, walls round it."""
    world = World.from_table({"x_min_m": -2.0, "y_min_m": -1.0, "width_m": 4, "height_m": 3})
    assert (world.x_min_m, world.y_min_m) == (-2.0, -1.0)
    assert world.clearance_m(0.0, 0.0) == 1.0
