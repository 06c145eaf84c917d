"""Success conditions of the delivery scenarios, read from the run's events.

``[success]`` keys (all optional):

- ``sounds_in_order = ["request_qr", ...]``: these sounds were played in this order
  (``delivery.sound`` events; others may come between).
- ``box_openings = N``: the box opened (90 degrees acknowledged) exactly N times; ``box_closed``:
  the last box move was a close.
- ``state_durations = [{ state, s, within_s }]``: every stay in ``state`` lasted ``s``
  (within ``within_s``, default 1 ms) and there was at least one.
- ``events_in_order = ["delivery.person_detected", ...]``: event kinds in this order.
- ``rejections = ["not_json", ...]``: the orders refused, with these reasons, in this order.
- ``delivered = [7]``: the orders handed over, in order.
- ``error_categories = ["lidar_lost"]``: the errors error_recovery recorded, in order.
"""

from __future__ import annotations

from typing import Any

from sim.slice import CheckRun, Events

PACED_SLACK_S = 0.25
"""A state's duration in a paced run may be this far off (a loaded machine's late wake-ups)."""
DELIVERY_SUCCESS_KEYS = ("sounds_in_order", "box_openings", "box_closed", "state_durations",
                         "events_in_order", "rejections", "delivered", "error_categories")


def _subsequence(want: list[Any], got: list[Any]) -> bool:
    it = iter(got)
    return all(any(w == g for g in it) for w in want)


def state_stays(events: list[dict[str, Any]], state: str) -> list[float]:
    """How long each stay in ``state`` (or a state inside it) lasted, in order."""
    stays: list[float] = []
    entered: float | None = None
    for e in events:
        if e.get("kind") != "transition":
            continue
        dst = str(e.get("dst", ""))
        inside = dst == state or dst.startswith(state + ".")
        if inside and entered is None:
            entered = float(e["t"])
        elif not inside and entered is not None:
            stays.append(float(e["t"]) - entered)
            entered = None
    return stays


def delivery_failures(extra: dict[str, Any], events: list[dict[str, Any]], *,
                      paced: bool = False) -> list[str]:
    """Every delivery condition of ``extra`` that does not hold, as a sentence (``paced``: the
    run followed the wall clock, ``--realtime``/``--speed``)."""
    reasons: list[str] = []
    kinds = [str(e.get("kind")) for e in events]
    if "sounds_in_order" in extra:
        played = [e.get("sound") for e in events if e.get("kind") == "delivery.sound"]
        if not _subsequence(list(extra["sounds_in_order"]), played):
            reasons.append(f"sounds {extra['sounds_in_order']} not played in order "
                           f"(played: {played})")
    boxes = [e.get("angle_deg") for e in events if e.get("kind") == "delivery.box"]
    if "box_openings" in extra and boxes.count(90) != int(extra["box_openings"]):
        reasons.append(f"box opened {boxes.count(90)} time(s), expected "
                       f"{extra['box_openings']} (moves: {boxes})")
    if extra.get("box_closed") and (not boxes or boxes[-1] != 0):
        reasons.append(f"box not closed at the end (moves: {boxes})")
    for want in extra.get("state_durations", []):
        state, s = str(want["state"]), float(want["s"])
        within = float(want.get("within_s", 0.001))
        if paced:  # on the wall clock a timer fires as late as the machine lets it
            within = max(within, PACED_SLACK_S)
        stays = state_stays(events, state)
        if not stays:
            reasons.append(f"never stayed in {state}")
        bad = [round(x, 4) for x in stays if abs(x - s) > within]
        if bad:
            reasons.append(f"{state} lasted {bad} s, expected {s:g} s (within {within:g} s)")
    if "events_in_order" in extra and not _subsequence(list(extra["events_in_order"]), kinds):
        reasons.append(f"events {extra['events_in_order']} did not happen in order")
    for key, kind, field in (("rejections", "delivery.order_invalid", "reason"),
                             ("delivered", "delivery.delivered", "order_id"),
                             ("error_categories", "delivery.recovery", "category")):
        if key in extra:
            got = [e.get(field) for e in events if e.get("kind") == kind]
            if got != list(extra[key]):
                reasons.append(f"{key}: {got}, expected {list(extra[key])}")
    return reasons


class DeliveryCheck:
    """The delivery robot's conditions (``DELIVERY_SUCCESS_KEYS``); it has no figures of its
    own beyond the navigation ones."""

    keys = DELIVERY_SUCCESS_KEYS

    def failures(self, run: CheckRun) -> list[str]:
        return delivery_failures(run.extra, run.events, paced=run.paced)

    def figures(self, events: Events) -> dict[str, Any]:
        return {}
