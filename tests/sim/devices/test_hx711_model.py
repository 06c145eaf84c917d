"""The simulated HX711 answers clock pulses bit by bit like the chip."""

from __future__ import annotations

import asyncio
import itertools
import math
import random
from collections.abc import Callable
from functools import partial

from hypothesis import example, given, settings
from hypothesis import strategies as st

from hal.ports import SckPulse
from sim import vclock
from sim.devices.hx711_model import SimHx711Lines, _clamp_code, _loop_s_reaching


class Bench:
    """A hand on the wires: a settable clock in seconds and whole-read helpers."""

    def __init__(self, kg: float = 0.0, sps: int = 10, **kwargs: object) -> None:
        self.t_s = 0.0
        self.kg = kg
        self.chip = SimHx711Lines(weight_kg=lambda: self.kg, sps=sps, noise_counts=0.0,
                                  clock=lambda: self.t_s, rng=random.Random(1),
                                  **kwargs)  # type: ignore[arg-type]

    def read(self, pulses: int = 25) -> int:
        raw = 0
        for i in range(pulses):
            self.chip.set_sck(True)
            if i < 24:
                raw = (raw << 1) | int(self.chip.read_dout())
            self.chip.set_sck(False)
        return raw - (1 << 24) if raw & 0x800000 else raw

    def wait_ready(self, step_s: float = 0.001, limit_s: float = 2.0) -> float:
        start = self.t_s
        while self.chip.read_dout():
            self.t_s += step_s
            assert self.t_s - start < limit_s, "never ready"
        return self.t_s - start


class TestSimHx711Lines:
    def test_dout_stays_high_while_settling_then_goes_low(self) -> None:
        """After power-up DOUT is high for the settling conversions (4 at 10 SPS: 400 ms)."""
        bench = Bench()
        waited = bench.wait_ready()
        assert 0.399 <= waited <= 0.402

    def test_shifts_out_offset_plus_scaled_weight(self) -> None:
        """The 24 bits are offset + counts_per_kg * kg, two's complement, MSB first."""
        bench = Bench(kg=2.0, offset_counts=-48_213, counts_per_kg=103_500.0)
        bench.wait_ready()
        assert bench.read() == -48_213 + 207_000
        bench.kg = -1.0  # a pull on the cell: negative codes
        bench.wait_ready()
        assert bench.read() == -48_213 - 103_500

    def test_conversions_come_at_the_output_rate(self) -> None:
        """At 80 SPS a new conversion is ready every 12.5 ms, DOUT high in between."""
        bench = Bench(sps=80)
        bench.wait_ready()
        bench.read()
        gaps = []
        for _ in range(5):
            gaps.append(bench.wait_ready(step_s=0.0001))
            bench.read()
        assert all(0.012 <= g <= 0.0126 for g in gaps)

    def test_gain_pulses_choose_the_next_conversion(self) -> None:
        """27 pulses: the next code is at gain 64 (half of 128); 26: channel B (no signal)."""
        bench = Bench(kg=4.0, offset_counts=0, counts_per_kg=100_000.0)
        bench.wait_ready()
        assert bench.read(27) == 400_000
        bench.wait_ready()
        assert bench.read(26) == 200_000
        assert bench.chip.gain == ("B", 32)
        bench.wait_ready()
        assert bench.read(25) == 0
        bench.wait_ready()
        assert bench.read() == 400_000
        assert bench.chip.pulse_counts == [27, 26, 25]

    def test_long_high_clock_powers_down_and_resets_to_a128(self) -> None:
        """PD_SCK high > 60 us: DOUT high (powered down); low again: reset, settle, A/128."""
        bench = Bench(kg=1.0, offset_counts=0, counts_per_kg=100_000.0)
        bench.wait_ready()
        bench.read(27)  # ask for A/64
        bench.chip.set_sck(True)
        bench.t_s += 0.001
        assert bench.chip.powered_down and bench.chip.read_dout() is True
        bench.chip.set_sck(False)
        assert bench.chip.power_downs == 1
        assert 0.399 <= bench.wait_ready() <= 0.402
        assert bench.read() == 100_000  # gain back to 128

    def test_glitch_switch_stretches_one_pulse(self) -> None:
        """glitch_next_read makes one pulse's high time exceed 60 us on the chip's clock."""
        bench = Bench()
        bench.wait_ready()
        bench.chip.glitch_next_read(at_pulse=5, high_us=80)
        widths = []
        for _ in range(25):
            t0 = bench.chip.now_us()
            bench.chip.set_sck(True)
            bench.chip.set_sck(False)
            widths.append(bench.chip.now_us() - t0)
        assert [i for i, w in enumerate(widths, 1) if w > 60] == [5]
        assert bench.chip.power_downs == 1

    def test_saturation_switch_gives_the_clipped_code(self) -> None:
        """saturate() shifts out 0x7FFFFF (or 0x800000 when low)."""
        bench = Bench()
        bench.wait_ready()
        bench.chip.saturate(high=True)
        assert bench.read() == 0x7FFFFF
        bench.chip.saturate(high=False)
        bench.wait_ready()
        assert bench.read() == -0x800000

    def test_pulses_while_not_ready_are_ignored(self) -> None:
        """Clocking while DOUT is high shifts nothing and starts no read."""
        bench = Bench(kg=1.0, offset_counts=0, counts_per_kg=100_000.0)
        for _ in range(10):
            bench.chip.set_sck(True)
            bench.chip.set_sck(False)
        assert bench.chip.reads_started == 0
        bench.wait_ready()
        assert bench.read() == 100_000

    def test_microseconds_advance_with_every_call_and_follow_the_loop(self) -> None:
        """now_us moves a little per GPIO call and never falls behind the clock."""
        bench = Bench()
        a = bench.chip.now_us()
        b = bench.chip.now_us()
        bench.t_s = 5.0
        c = bench.chip.now_us()
        assert b == a + 1 and c == 5_000_000

    def test_a_load_that_is_not_a_number_reads_as_out_of_range(self) -> None:
        """A NaN or infinite payload (a scenario typo) gives the clipped codes, not a crash."""
        for kg, code in ((float("nan"), 0x7FFFFF), (float("inf"), 0x7FFFFF),
                         (float("-inf"), -0x800000)):
            bench = Bench(kg=kg)
            bench.wait_ready()
            assert bench.read() == code

    def test_lost_gpio_raises_oserror_until_restored(self) -> None:
        """lose_gpio() makes every line access raise OSError (as lgpio does) until restored."""
        bench = Bench()
        bench.chip.lose_gpio()
        for access in (bench.chip.read_dout, lambda: bench.chip.set_sck(True)):
            try:
                access()
            except OSError as exc:
                assert "No such device" in str(exc)
            else:
                raise AssertionError("no OSError")
        bench.chip.restore_gpio()
        bench.wait_ready()


class TestDoutAlert:
    def test_calls_back_at_the_first_instant_dout_reads_low(self) -> None:
        """``on_dout_low`` fires when the conversion completes: DOUT reads low then, and the
        loop clock a hair earlier gives a microsecond that is not ready yet."""
        async def main() -> list[tuple[float, bool, bool]]:
            loop = asyncio.get_running_loop()
            await asyncio.sleep(12.345678)  # a clock far from zero, where floats are coarse
            chip = SimHx711Lines(weight_kg=lambda: 1.0, sps=80, clock=loop.time)
            seen: list[tuple[float, bool, bool]] = []
            for _ in range(6):
                fired = asyncio.Event()
                chip.on_dout_low(fired.set)
                await fired.wait()
                now = loop.time()
                earlier_us = int(math.nextafter(now, -math.inf) * 1_000_000)
                seen.append((now, chip.read_dout(), earlier_us >= chip._first_ready_us
                             + (chip._last_read_index + 1) * chip.period_us))
                for _ in range(25):
                    chip.set_sck(True)
                    chip.set_sck(False)
            return seen

        seen = vclock.run(main())
        assert [low for _, low, _ in seen] == [False] * 6
        assert [early for _, _, early in seen] == [False] * 6
        gaps = [b[0] - a[0] for a, b in itertools.pairwise(seen)]
        assert all(abs(g - 0.0125) < 1e-6 for g in gaps)

    def test_cancel_and_wire_switches(self) -> None:
        """A cancelled wait is not called; a pulled wire holds it off until reconnected; a
        lost GPIO chip calls at once (the reader's next access raises)."""
        async def main() -> tuple[list[str], float]:
            loop = asyncio.get_running_loop()
            chip = SimHx711Lines(weight_kg=lambda: 1.0, sps=10, clock=loop.time)
            calls: list[str] = []
            cancel = chip.on_dout_low(lambda: calls.append("cancelled"))
            cancel()
            chip.disconnect()
            chip.on_dout_low(lambda: calls.append(f"wire {loop.time():.1f}"))
            await asyncio.sleep(1.0)
            chip.connect()
            await asyncio.sleep(0)
            chip.lose_gpio()
            chip.on_dout_low(lambda: calls.append("lost"))
            await asyncio.sleep(0)
            return calls, loop.time()

        calls, _ = vclock.run(main())
        assert calls == ["wire 1.0", "lost"]


_PULSE_STEPS = st.lists(st.one_of(
    st.tuples(st.just("pulse")), st.tuples(st.just("pulse_read")),
    st.tuples(st.just("pulse_read")), st.tuples(st.just("read")),
    st.tuples(st.just("sck"), st.booleans()),
    st.tuples(st.just("advance"), st.sampled_from([1e-6, 5e-5, 1e-4, 0.002, 0.0125, 0.1])),
    st.tuples(st.just("glitch"), st.integers(0, 27), st.integers(0, 100)),
    st.tuples(st.sampled_from(["wait", "lose", "restore", "disconnect", "connect"]))),
    max_size=120)


def _chip_state(chip: SimHx711Lines) -> tuple[object, ...]:
    timer = chip._dout_timer
    return (chip._now_us, chip._rise_us, chip._sck, chip._pulses, chip._pulses_per_read,
            chip._last_read_index, chip._first_ready_us, chip._glitch, chip.pulses_total,
            chip.reads_started, chip.reads_completed, chip.power_downs,
            tuple(chip.pulse_counts), len(chip._dout_waiters),
            None if timer is None else getattr(timer, "_when", "soon"))


class TestPulseSck:
    def test_the_sim_lines_offer_one_call_pulses(self) -> None:
        """``SimHx711Lines`` is a ``hal.ports.SckPulse``."""
        assert isinstance(SimHx711Lines(weight_kg=lambda: 0.0), SckPulse)

    @settings(max_examples=200, deadline=None)
    @example(steps=[("wait",)] + [("pulse",), ("read",)] * 25, call_us=1)
    @example(steps=[("pulse_read",)] * 24 + [("pulse",)] + [("advance", 0.1)]
             + [("pulse_read",)] * 30, call_us=1)
    @example(steps=[("glitch", 5, 80)] + [("pulse",), ("read",)] * 25 + [("advance", 0.1)]
             + [("pulse",)] * 27, call_us=1)
    @given(steps=_PULSE_STEPS, call_us=st.sampled_from([-1, 0, 1, 3, 61]))
    def test_one_call_does_what_the_four_do(self, steps: list[tuple[object, ...]],
                                            call_us: int) -> None:
        """``pulse_sck()`` returns what ``now_us``, ``set_sck(True)``, ``set_sck(False)``,
        ``now_us`` give and leaves the chip as they do (``pulse_sck_read()``: and then
        ``read_dout()``), through whole reads, stray pulses, SCK left high, glitches, a lost
        GPIO chip, a pulled wire and waiting readers."""
        async def main() -> None:
            clock = {"s": 3.0}
            fast, plain = (SimHx711Lines(weight_kg=lambda: 2.5, sps=80, call_us=call_us,
                                         rng=random.Random(7), clock=lambda: clock["s"])
                           for _ in range(2))

            def by_edges(chip: SimHx711Lines) -> int:
                t0 = chip.now_us()
                chip.set_sck(True)
                chip.set_sck(False)
                return chip.now_us() - t0

            def outcome(do: Callable[[], object]) -> object:
                try:
                    return do()
                except OSError as exc:
                    return exc.errno

            clock["s"] += 0.06  # the chips have settled: a conversion is ready
            for name, *args in steps:
                if name == "advance":
                    clock["s"] += float(args[0])  # type: ignore[arg-type]
                    continue
                for chip in (fast, plain):
                    if name == "glitch":
                        chip.glitch_next_read(*args)  # type: ignore[arg-type]
                    elif name == "wait":
                        chip.on_dout_low(lambda: None)
                    elif name in ("lose", "restore", "disconnect", "connect"):
                        getattr(chip, {"lose": "lose_gpio", "restore": "restore_gpio"}
                                .get(name, name))()
                got: tuple[object, object] = (None, None)
                if name == "pulse":
                    got = outcome(fast.pulse_sck), outcome(partial(by_edges, plain))
                elif name == "pulse_read":
                    got = (outcome(fast.pulse_sck_read),
                           outcome(lambda: (by_edges(plain), plain.read_dout())))
                elif name == "read":
                    got = outcome(fast.read_dout), outcome(plain.read_dout)
                elif name == "sck":
                    got = (outcome(partial(fast.set_sck, bool(args[0]))),
                           outcome(partial(plain.set_sck, bool(args[0]))))
                assert got[0] == got[1]
                assert _chip_state(fast) == _chip_state(plain)

        vclock.run(main())


@example(code=float("nan"))
@example(code=0x7FFFFF - 0.5)
@example(code=-0x800000 + 0.5)
@example(code=-0x800000 + 1.0)
@given(st.one_of(st.floats(allow_nan=True, allow_infinity=True),
                 st.floats(-0x800002, 0x800002)))
def test_clamp_code_is_floor_then_the_24_bit_range(code: float) -> None:
    """The code of a conversion is its value floored and clipped to 0x800000..0x7FFFFF, and
    NaN the high limit: what ``int(max(MIN, min(MAX, floor(max(-1e12, min(1e12, v))))))``
    with NaN checked first gives."""
    expected = 0x7FFFFF if math.isnan(code) else int(
        max(-0x800000, min(0x7FFFFF, math.floor(max(-1e12, min(1e12, code))))))
    got = _clamp_code(code)
    assert got == expected and type(got) is int


@given(st.integers(0, 10**12))
def test_loop_s_reaching_is_the_first_clock_reading_at_the_microsecond(us: int) -> None:
    """The returned seconds reach ``us`` when truncated to microseconds; the float before
    them does not."""
    s = _loop_s_reaching(us)
    assert int(s * 1_000_000) >= us
    assert s == 0.0 or int(math.nextafter(s, -math.inf) * 1_000_000) < us
