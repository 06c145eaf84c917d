"""RelayBot's state table against the seed: every state and arrow, timers, and the outputs."""

from __future__ import annotations

import asyncio
from collections.abc import Awaitable, Callable
from typing import Any

import structlog
from delivery_table_rig import TableProfile, TableRig
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from behaviours.context import RobotContext
from behaviours.profiles.delivery import states
from behaviours.profiles.delivery.states import (
    BOX_CLOSED_DEG,
    BOX_OPEN_DEG,
    STATE_LEDS,
    STATES,
    outputs_for,
)
from hal.readings import LedMode
from sim import vclock

TRIGGERS = sorted({t["trigger"] for t in states.mission_transitions()})

# The seed's state diagram, arrow by arrow (seed names → ours), to read beside it.
SEED_DIAGRAM = [
    ("Waiting", "Approaching", "Person detected in zone", "person_detected"),
    ("Approaching", "Waiting", "Person disappears", "person_lost"),
    ("Approaching", "Verifying", "Reached customer (< 50cm)", "reached_customer"),
    ("Verifying", "NavigatingToWarehouse", "Order valid", "order_valid"),
    ("Verifying", "Waiting", "Order invalid", "order_invalid"),
    ("Verifying", "Waiting", "timeout (30 s)", "timeout"),
    ("NavigatingToWarehouse", "Loading", "Reached warehouse zone", "reached_warehouse"),
    ("Loading", "ReturningToCustomer", "Loading confirmed", "loading_confirmed"),
    ("ReturningToCustomer", "Delivering", "Reached customer coords", "reached_customer"),
    ("Delivering", "Resetting", "Delivery complete (10s elapsed)", "delivery_complete"),
    ("Resetting", "Waiting", "Reached home position", "reached_home"),
    ("Approaching", "ErrorRecovery", "Navigation error", "navigation_error"),
    ("NavigatingToWarehouse", "ErrorRecovery", "Navigation error", "navigation_error"),
    ("ReturningToCustomer", "ErrorRecovery", "Navigation error", "navigation_error"),
    ("Resetting", "ErrorRecovery", "Navigation error", "navigation_error"),
    ("ErrorRecovery", "Waiting", "Recovery complete", "recovery_complete"),
    # The error table's rows that are transitions:
    ("Loading", "ErrorRecovery", "State timeout LOADING 60 s", "timeout"),
    ("Delivering", "ErrorRecovery", "State timeout DELIVERING 15 s", "timeout"),
    ("ErrorRecovery", "EMERGENCY_STOP", "Home navigation failed 3 times", "recovery_failed"),
]

SEED_TO_OURS = {"Waiting": "waiting", "Approaching": "approaching", "Verifying": "verifying",
                "NavigatingToWarehouse": "navigating_to_warehouse", "Loading": "loading",
                "ReturningToCustomer": "returning_to_customer", "Delivering": "delivering",
                "Resetting": "resetting", "ErrorRecovery": "error_recovery"}


def ours(seed_name: str) -> str:
    return "estop" if seed_name == "EMERGENCY_STOP" else f"mission.{SEED_TO_OURS[seed_name]}"


def run(body: Callable[[TableRig], Awaitable[Any]], tasks: dict[str, Any] | None = None) -> Any:
    async def main() -> Any:
        rig = TableRig(TableProfile(tasks))
        await rig.start()
        try:
            return await body(rig)
        finally:
            await rig.close()

    return vclock.run(main())


async def drive_to(rig: TableRig, state: str) -> None:
    """Walk the happy path from waiting to ``state`` (a name from STATES)."""
    happy = [("person_detected", "approaching"), ("reached_customer", "verifying"),
             ("order_valid", "navigating_to_warehouse"), ("reached_warehouse", "loading"),
             ("loading_confirmed", "returning_to_customer"), ("reached_customer", "delivering"),
             ("delivery_complete", "resetting")]
    if state == "error_recovery":
        assert await rig.machine.trigger("error")
        return
    for trigger, reached in happy:
        if rig.machine.state == f"mission.{state}":
            return
        assert await rig.machine.trigger(trigger), (trigger, rig.machine.state)
        assert rig.machine.state == f"mission.{reached}"


class TestTheSeedsDiagram:
    def test_the_nine_states_with_the_seeds_names(self) -> None:
        """STATES are the seed's nine, snake_case, in its order, all under mission."""
        assert [SEED_TO_OURS[s] for s in SEED_TO_OURS] == list(STATES)
        names = [s if isinstance(s, str) else s["name"] for s in states.mission_states()]
        assert names == list(STATES)

    def test_every_arrow_of_the_diagram_is_in_the_table(self) -> None:
        """Each seed arrow is a transition with its trigger; the table has no others."""
        table = {(src, t["dest"], t["trigger"])
                 for t in states.mission_transitions()
                 for src in (t["source"] if isinstance(t["source"], list) else [t["source"]])}
        seed = {(ours(a), ours(b), trigger) for a, b, _, trigger in SEED_DIAGRAM}
        assert seed <= table
        extra = {row for row in table - seed if row[2] != "error"}
        assert extra == set()

    def test_every_arrow_fires_on_the_machine(self) -> None:
        """Starting from its source, each arrow's trigger lands in its destination."""
        for src, dst, _, trigger in SEED_DIAGRAM:
            async def body(rig: TableRig, src: str = src, dst: str = dst,
                           trigger: str = trigger) -> None:
                await drive_to(rig, SEED_TO_OURS[src])
                assert rig.machine.state == ours(src)
                assert await rig.machine.trigger(trigger), (src, trigger)
                assert rig.machine.state == ours(dst)

            run(body)

    def test_callbacks_resolve(self) -> None:
        """Every callback the delivery tables name exists on the machine model."""
        async def body(rig: TableRig) -> list[str]:
            return rig.machine.missing_callbacks()

        assert run(body) == []


class TestTimers:
    def check_timeout(self, state: str, after_s: float, dest: str) -> None:
        async def body(rig: TableRig) -> tuple[float, str]:
            await drive_to(rig, state)
            t0 = asyncio.get_running_loop().time()
            await rig.left(f"mission.{state}")
            return rig.moves[-1][0] - t0, rig.machine.state

        waited_s, reached = run(body)
        assert abs(waited_s - after_s) < 1e-6 and reached == dest

    def test_verifying_gives_up_after_30_s(self) -> None:
        """No valid QR in 30 s: back to waiting (the diagram's 'timeout')."""
        self.check_timeout("verifying", 30.0, "mission.waiting")

    def test_loading_gives_up_after_60_s(self) -> None:
        """Nobody confirms loading in 60 s: error_recovery (the error table)."""
        self.check_timeout("loading", 60.0, "mission.error_recovery")

    def test_delivering_hard_limit_is_15_s(self) -> None:
        """A hand-over that never completes ends in error_recovery at 15 s."""
        self.check_timeout("delivering", 15.0, "mission.error_recovery")


async def hand_over(ctx: RobotContext) -> None:
    """The delivering state's timer: the box stays open DELIVERY_DURATION_S, then complete."""
    await asyncio.sleep(states.DELIVERY_DURATION_S)
    await ctx.trigger("delivery_complete")


# Feature: relaybot-autonomous-delivery, Property 22: For any delivery in DELIVERING state, the
# state should remain DELIVERING for exactly 10 seconds before transitioning to RESETTING.
@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.floats(0.0, 100.0))
def test_property_22_delivering_lasts_exactly_10_s(arrive_after_s: float) -> None:
    """Whenever the robot arrives, delivering lasts 10.0 s of loop time, then resetting."""
    async def body(rig: TableRig) -> tuple[float, str]:
        await drive_to(rig, "returning_to_customer")
        await asyncio.sleep(arrive_after_s)
        await rig.machine.trigger("reached_customer")
        await rig.left("mission.delivering")
        entered = next(t for t, _, d, _ in rig.moves if d == "mission.delivering")
        return rig.moves[-1][0] - entered, rig.machine.state

    lasted_s, after = run(body, {"mission.delivering": hand_over})
    # Exactly 10 s of loop time, to the float rounding of adding times (1e-9 s).
    assert abs(lasted_s - states.DELIVERY_DURATION_S) < 1e-9 and after == "mission.resetting"


# Feature: relaybot-autonomous-delivery, Property 2: For any person detected in the delivery zone
# while in WAITING state, the state machine should transition to APPROACHING state.
# Feature: relaybot-autonomous-delivery, Property 3: For any customer tracking loss during
# APPROACHING state, the robot should stop movement and transition back to WAITING state.
# Feature: relaybot-autonomous-delivery, Property 4: For any approach to customer, when distance
# becomes less than 50cm, the state machine should stop and transition to VERIFYING state.
# (The table's part; detecting the person and measuring 50 cm are the mission's.)
@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from(["person_lost", "reached_customer"]))
def test_properties_2_3_4_the_approach_arrows(outcome: str) -> None:
    """waiting --person_detected--> approaching, then lost → waiting, reached → verifying."""
    async def body(rig: TableRig) -> list[str]:
        assert await rig.machine.trigger("person_detected")
        seen = [rig.machine.state]
        assert await rig.machine.trigger(outcome)
        return [*seen, rig.machine.state]

    expected = "mission.waiting" if outcome == "person_lost" else "mission.verifying"
    assert run(body) == ["mission.approaching", expected]


# Feature: relaybot-autonomous-delivery, Property 12: For any state transition, a log entry should
# be created containing old state, new state, and timestamp.
# State machine errors (error table): an invalid transition is logged and the state is kept.
@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(st.sampled_from(TRIGGERS), min_size=1, max_size=12))
def test_property_12_and_invalid_triggers(triggers: list[str]) -> None:
    """Any trigger sequence: refused ones keep the state (and are logged), accepted ones are
    recorded with old state, new state, trigger and time."""
    async def body(rig: TableRig) -> None:
        for trigger in triggers:
            before = rig.machine.state
            allowed = trigger in rig.machine.allowed_triggers()
            moves_before = len(rig.moves)
            with structlog.testing.capture_logs() as logs:
                fired = await rig.machine.trigger(trigger)
            assert fired == allowed
            if not fired:
                assert rig.machine.state == before
                assert any(e["event"] == "state.refused" and e["trigger"] == trigger
                           for e in logs)
            else:
                t_s, src, dst, name = rig.moves[moves_before]
                assert (src, name) == (before, trigger) and dst == rig.machine.state
                assert t_s == asyncio.get_running_loop().time()

    run(body)


# Feature: relaybot-autonomous-delivery, Property 13: For any error condition in any state, the
# error handler should navigate the robot back to home position (0,0) and transition to WAITING
# state. (The table's part: from every state an error reaches error_recovery, which stops the
# motors and leaves only to waiting, or to estop after 3 failed attempts.)
@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from([s for s in STATES if s != "error_recovery"]))
def test_property_13_errors_go_through_recovery_to_waiting(state: str) -> None:
    """error from any state → error_recovery (motors stopped) → recovery_complete → waiting."""
    async def body(rig: TableRig) -> list[str]:
        await drive_to(rig, state)
        stops = rig.motor_stops
        assert await rig.machine.trigger("error")
        seen = [rig.machine.state]
        assert rig.motor_stops > stops
        assert {"recovery_complete", "recovery_failed"} <= set(rig.machine.allowed_triggers())
        assert await rig.machine.trigger("recovery_complete")
        return [*seen, rig.machine.state]

    assert run(body) == ["mission.error_recovery", "mission.waiting"]


# --- outputs --------------------------------------------------------------------------------
ARROWS = [(src, t["trigger"], t["dest"].removeprefix("mission."))
          for t in states.mission_transitions()
          for src in (t["source"] if isinstance(t["source"], list) else [t["source"]])]
ARROWS = [(src.removeprefix("mission."), trig, dst) for src, trig, dst in ARROWS]


# Feature: relaybot-autonomous-delivery, Property 19: For any state transition, the appropriate
# LED command should be sent to Arduino (WAITING→idle, APPROACHING→moving, LOADING→waiting, etc.).
@settings(max_examples=100)
@given(st.sampled_from(ARROWS), st.integers(1, 10**6))
def test_property_19_state_leds(arrow: tuple[str, str, str], order_id: int) -> None:
    """Every transition into one of the nine states ends with that state's LED command."""
    src, trigger, dst = arrow
    leds = outputs_for(src, trigger, dst, order_id).leds
    if dst in STATE_LEDS:
        assert leds[-1] == STATE_LEDS[dst]
    assert STATE_LEDS["waiting"] == LedMode.IDLE and STATE_LEDS["approaching"] == LedMode.MOVING
    assert STATE_LEDS["loading"] == LedMode.WAITING


# Feature: relaybot-autonomous-delivery, Property 20: For any state requiring open box (LOADING
# or DELIVERING), the servo command should be sent with angle 90 degrees.
# Feature: relaybot-autonomous-delivery, Property 21: For any box close trigger (loading
# confirmation, delivery timeout), the servo command should be sent with angle 0 degrees.
@settings(max_examples=100)
@given(st.sampled_from(ARROWS))
def test_properties_20_21_box(arrow: tuple[str, str, str]) -> None:
    """Entering loading/delivering opens at 90; leaving them closes at 0 (first)."""
    src, trigger, dst = arrow
    box = outputs_for(src, trigger, dst).box_deg
    if dst in ("loading", "delivering"):
        assert box[-1] == BOX_OPEN_DEG
    if src in ("loading", "delivering"):
        assert box[0] == BOX_CLOSED_DEG
    if dst == "error_recovery":
        assert box[-1] == BOX_CLOSED_DEG
    assert all(angle in (BOX_OPEN_DEG, BOX_CLOSED_DEG) for angle in box)


# Feature: relaybot-autonomous-delivery, Property 23: For any state requiring audio feedback
# (VERIFYING→request QR, LOADING→announce order, DELIVERING→greet customer), the correct audio
# file should be played.
# Feature: relaybot-autonomous-delivery, Property 7 (the table's part): an invalid order triggers
# the rejection audio and returns to WAITING.
@settings(max_examples=100)
@given(st.sampled_from(ARROWS), st.integers(1, 10**6))
def test_property_23_state_sounds(arrow: tuple[str, str, str], order_id: int) -> None:
    """The seed's sounds for verifying, loading (with the order's number), delivering, and the
    rejection."""
    src, trigger, dst = arrow
    sounds = outputs_for(src, trigger, dst, order_id).sounds
    expected = {"verifying": "request_qr", "loading": f"announce_order_{order_id}",
                "delivering": "delivery_greeting"}
    if dst in expected:
        assert sounds[-1] == expected[dst]
    if trigger == "order_invalid":
        assert "order_rejected" in sounds and dst == "waiting"
    if trigger == "order_valid":
        assert "order_accepted" in sounds
