"""HX711 bit-banging on recorded bit sequences: two's complement, gain pulses, glitches."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from drivers.hx711 import Gain, ReadDiscarded, clock_out, to_signed24


class RecordedLines:
    """Plays a recorded 24-bit DOUT sequence; each pulse stays high ``high_us[n]`` (else 2)."""

    def __init__(self, code24: int, high_us: dict[int, int] | None = None) -> None:
        self.bits = [(code24 >> (23 - i)) & 1 for i in range(24)]
        self.high_us = high_us or {}
        self.t_us = 1000
        self.pulses = 0
        self.sck = False
        self.edges: list[bool] = []

    def now_us(self) -> int:
        return self.t_us

    def set_sck(self, high: bool) -> None:
        self.edges.append(high)
        self.sck = high
        if high:
            self.pulses += 1
            self.t_us += self.high_us.get(self.pulses, 2)
        else:
            self.t_us += 1

    def read_dout(self) -> bool:
        if 1 <= self.pulses <= 24:
            return bool(self.bits[self.pulses - 1])
        return True


class PulsingLines(RecordedLines):
    """The same recording, clocked by ``pulse_sck`` and ``pulse_sck_read``
    (``hal.ports.SckPulse``)."""

    def __init__(self, code24: int, high_us: dict[int, int] | None = None) -> None:
        super().__init__(code24, high_us)
        self.pulse_calls = 0

    def pulse_sck(self) -> int:
        self.pulse_calls += 1
        t0 = self.now_us()
        self.set_sck(True)
        self.set_sck(False)
        return self.now_us() - t0

    def pulse_sck_read(self) -> tuple[int, bool]:
        high_us = self.pulse_sck()
        return high_us, self.read_dout()


class TestToSigned24:
    def test_twos_complement(self) -> None:
        """0x000001 is 1, 0xFFFFFF is -1, 0x800001 is the most negative legal code."""
        assert [to_signed24(c) for c in (0x000001, 0xFFFFFF, 0x800001, 0x7FFFFE)] == [
            1, -1, -8388607, 8388606]


class TestClockOut:
    @pytest.mark.parametrize(("code24", "value"), [
        (0x01E240, 123456), (0xFE1DC0, -123456), (0x000000, 0), (0xFFFFFF, -1),
        (0x7FFFFE, 8388606), (0x800001, -8388607)])
    def test_recorded_sequences_decode_msb_first(self, code24: int, value: int) -> None:
        """24 bits, MSB first, read as two's complement."""
        assert clock_out(RecordedLines(code24), Gain.A128) == value

    @pytest.mark.parametrize(("gain", "pulses"), [(Gain.A128, 25), (Gain.B32, 26),
                                                  (Gain.A64, 27)])
    def test_pulse_count_selects_channel_and_gain(self, gain: Gain, pulses: int) -> None:
        """25, 26 or 27 pulses in all, and PD_SCK is left low (chip stays powered)."""
        lines = RecordedLines(0x01E240)
        clock_out(lines, gain)
        assert lines.pulses == pulses
        assert lines.edges == [True, False] * pulses

    @pytest.mark.parametrize("code24", [0x7FFFFF, 0x800000])
    def test_saturated_codes_are_rejected(self, code24: int) -> None:
        """The chip's out-of-range codes 0x7FFFFF and 0x800000 are discarded."""
        with pytest.raises(ReadDiscarded) as err:
            clock_out(RecordedLines(code24), Gain.A128)
        assert err.value.reason == "saturated"

    @pytest.mark.parametrize("pulse", [1, 12, 24, 25, 27])
    def test_a_long_clock_pulse_discards_the_read(self, pulse: int) -> None:
        """A pulse high for more than 60 us (the chip powers down) discards the read."""
        lines = RecordedLines(0x01E240, {pulse: 80})
        with pytest.raises(ReadDiscarded, match="81 us") as err:
            clock_out(lines, Gain.A64)
        assert err.value.reason == "sck_high"
        assert lines.pulses == 27  # the read is clocked to the end anyway

    def test_sixty_microseconds_is_still_fine(self) -> None:
        """A pulse measured at exactly 60 us is accepted; 61 us is not."""
        assert clock_out(RecordedLines(0x01E240, {5: 59}), Gain.A128) == 123456
        with pytest.raises(ReadDiscarded):
            clock_out(RecordedLines(0x01E240, {5: 60}), Gain.A128)

    @given(code24=st.integers(0, 0xFFFFFF), gain=st.sampled_from(Gain),
           long_pulse=st.integers(1, 27), long_us=st.integers(0, 100))
    def test_lines_with_pulse_sck_are_clocked_through_it(self, code24: int, gain: Gain,
                                                         long_pulse: int,
                                                         long_us: int) -> None:
        """Lines that offer ``pulse_sck`` and ``pulse_sck_read`` get one call per pulse and
        give the same code, or the same discard, as clocking them edge by edge."""
        def result(lines: RecordedLines) -> object:
            try:
                return clock_out(lines, gain)
            except ReadDiscarded as exc:
                return str(exc)

        pulsing = PulsingLines(code24, {long_pulse: long_us})
        assert result(pulsing) == result(RecordedLines(code24, {long_pulse: long_us}))
        assert pulsing.pulse_calls == gain.pulses

    @given(st.integers(-0x7FFFFF, 0x7FFFFE))
    def test_every_legal_code_round_trips(self, value: int) -> None:
        """Any code the chip can send unsaturated is read back as the same signed value."""
        assert clock_out(RecordedLines(value & 0xFFFFFF), Gain.A128) == value
