"""The encoder watch: driven wheels with frozen ticks are an encoder failure, ticks that move
again are its end; a stopped robot or a slow command is never a failure."""

from __future__ import annotations

from typing import Any

from hypothesis import given, settings
from hypothesis import strategies as st

from behaviours.motion.encoder_watch import EncoderWatch, EncoderWatchConfig
from hal.readings import EncoderReading


class _Encoders:
    """The newest reading, set by the test (no I/O)."""

    def __init__(self) -> None:
        self.reading: EncoderReading | None = None

    def latest(self) -> EncoderReading | None:
        return self.reading

    async def next_reading(self) -> EncoderReading:  # pragma: no cover - not used
        raise NotImplementedError


def _watch(pwm: list[int]) -> tuple[_Encoders, EncoderWatch, list[tuple[bool, dict[str, Any]]]]:
    encoders = _Encoders()
    changes: list[tuple[bool, dict[str, Any]]] = []
    watch = EncoderWatch(encoders, lambda: pwm[0], lambda f, d: changes.append((f, d)),
                         EncoderWatchConfig(freeze_s=0.5, min_pwm=40))
    return encoders, watch, changes


def test_frozen_ticks_while_driven_fail_after_freeze_s_and_return_on_change() -> None:
    """Ticks that stay put for 0.5 s under PWM 98 fail once; the next change brings them back."""
    pwm = [98]
    encoders, watch, changes = _watch(pwm)
    for i in range(10):  # moving: ticks change every 0.1 s
        encoders.reading = EncoderReading(i * 10, i * 10, i * 0.1)
        watch.check(i * 0.1)
    assert changes == []
    for i in range(10, 20):  # frozen at 90, still read at 0.05 s intervals
        encoders.reading = EncoderReading(90, 90, i * 0.1)
        watch.check(i * 0.1)
    assert [f for f, _ in changes] == [True]
    failed = changes[0][1]
    assert failed["category"] == "encoder" and failed["reason"] == "frozen"
    assert failed["commanded_pwm"] == 98 and failed["frozen_s"] >= 0.5
    encoders.reading = EncoderReading(95, 96, 2.0)
    watch.check(2.0)
    assert [f for f, _ in changes] == [True, False]
    assert not watch.failed and watch.failures == 1


def test_no_telemetry_while_driven_is_a_failure() -> None:
    """No ENCODER lines at all while the wheels are driven: failed, reason no_telemetry."""
    pwm = [120]
    encoders, watch, changes = _watch(pwm)
    encoders.reading = EncoderReading(5, 5, 0.0)
    for i in range(12):
        watch.check(i * 0.1)
    assert changes and changes[0][1]["reason"] == "no_telemetry"


@settings(max_examples=100, deadline=None)
@given(st.lists(st.integers(0, 39), min_size=1, max_size=80))
def test_slow_or_stopped_wheels_never_fail(commands: list[int]) -> None:
    """Commands under min_pwm (stopped, creeping) with frozen ticks never count as a failure."""
    pwm = [0]
    encoders, watch, changes = _watch(pwm)
    encoders.reading = EncoderReading(0, 0, 0.0)
    for i, command in enumerate(commands):
        pwm[0] = command
        watch.check(i * 0.1)
    assert changes == []


@settings(max_examples=100, deadline=None)
@given(st.integers(40, 255), st.integers(1, 4))
def test_driven_wheels_with_moving_ticks_never_fail(command: int, every: int) -> None:
    """Ticks that change at least every 0.4 s under any PWM never fail (0.5 s is the limit)."""
    pwm = [command]
    encoders, watch, changes = _watch(pwm)
    for i in range(60):
        if i % every == 0:
            encoders.reading = EncoderReading(i, -i, i * 0.1)
        watch.check(i * 0.1)
    assert changes == []
