"""The motor board link as the delivery seed asks of it: command latency and no loss at
10 commands a second (the real driver against the fake board, bytes on a simulated UART)."""

from __future__ import annotations

import asyncio

from arduino_bench import Bench, on_bench
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from hal.readings import LedMode, MotorCommand

PWM = st.integers(0, 255)
MOTOR = st.builds(MotorCommand, PWM, PWM, st.booleans(), st.booleans())
COMMAND = st.one_of(
    MOTOR.map(lambda m: ("motor", m)),
    st.integers(0, 180).map(lambda a: ("servo", a)),
    st.sampled_from(list(LedMode)).map(lambda m: ("led", m)),
)


# Feature: relaybot-autonomous-delivery, Property 17: For any motor command sent from Raspberry
# Pi, the Arduino should execute the command within 100ms.
@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(MOTOR, min_size=1, max_size=5))
def test_property_17_motor_commands_execute_within_100_ms(commands: list[MotorCommand]) -> None:
    """Each MOTOR command is executed by the board within 100 ms of ``drive`` (at 115200
    baud, through the framing, the resend logic and the board's parser)."""

    async def scenario(bench: Bench) -> None:
        loop = asyncio.get_running_loop()
        await asyncio.sleep(0.2)  # handshake done
        for command in commands:
            sent_s = loop.time()
            await bench.link.drive(command)
            await asyncio.sleep(0.15)
            done = [e for e in bench.mcu.executed
                    if e.payload.startswith("MOTOR:") and e.t_s >= sent_s]
            assert done, "the MOTOR command was never executed"
            assert done[0].t_s - sent_s <= 0.100

    on_bench(scenario, heartbeat_s=30.0)


# Feature: relaybot-autonomous-delivery, Property 18: For any sequence of serial commands sent
# rapidly (up to 10 commands/second), all commands should be received and acknowledged without
# loss.
@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(COMMAND, min_size=1, max_size=20))
def test_property_18_ten_commands_a_second_all_acknowledged(
        commands: list[tuple[str, object]]) -> None:
    """MOTOR, SERVO and LED commands, one every 100 ms: every one is acknowledged and the
    board executed each, in order."""

    async def scenario(bench: Bench) -> None:
        await asyncio.sleep(0.2)
        start_s = asyncio.get_running_loop().time()
        sent: list[str] = []
        for kind, value in commands:
            if kind == "motor":
                assert isinstance(value, MotorCommand)
                await bench.link.drive(value)
                sent.append("MOTOR:")
            elif kind == "servo":
                assert isinstance(value, int)
                await bench.link.set_angle(value)  # raises unless acknowledged
                sent.append(f"SERVO:{value}")
            else:
                assert isinstance(value, LedMode)
                await bench.link.show(value)
                sent.append("LED")
            await asyncio.sleep(0.1)
        await asyncio.sleep(0.3)
        executed = [e.payload for e in bench.mcu.executed
                    if e.t_s >= start_s and e.payload not in ("HB", "HELLO")]
        for want, got in zip(sent, executed, strict=True):
            if want == "LED":
                assert not got.startswith(("MOTOR", "SERVO"))
            else:
                assert got.startswith(want)
        status = bench.link.status()
        assert (status["lost"], status["dropped"], status["nak"], status["superseded"]) == (
            0, 0, 0, 0)

    on_bench(scenario, heartbeat_s=30.0)
