"""The HX711 driver against the bit-level simulated chip, under virtual time."""

from __future__ import annotations

import asyncio
import random
import statistics
from collections import deque
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from drivers.hx711 import Gain, Hx711
from drivers.hx711_filter import _median
from hal.devices import DeviceUnavailable, LoadCell
from sim import vclock
from sim.devices.hx711_model import SimHx711Lines
from sim.world.body import DiffDriveBody
from sim.world.floor_plan import World
from sim.world.geometry import Pose


def _rig(gain: Gain = Gain.A128, sps: int = 10, **sim: Any) -> tuple[
        DiffDriveBody, SimHx711Lines, Hx711]:
    body = DiffDriveBody(World.from_table({"width_m": 4, "height_m": 4}), Pose(1, 1, 0))
    lines = SimHx711Lines.on_body(body, sps=sps, rng=random.Random(3), **sim)
    # The configured factor is the default for a 20 kg cell; the sim's real scale differs.
    return body, lines, Hx711(lambda: lines, gain=gain, sps=sps)


async def _settle(hx: Hx711, readings: int = 20) -> float:
    for _ in range(readings):
        reading = await hx.next_reading()
    return reading.kg


class TestHx711Driver:
    def test_implements_the_hal_protocol(self) -> None:
        """The driver is a ``hal.devices.LoadCell``."""
        assert isinstance(_rig()[2], LoadCell)

    @pytest.mark.parametrize(("gain", "sps"), [(Gain.A128, 10), (Gain.A128, 80),
                                               (Gain.A64, 10)])
    def test_reads_the_payload_after_tare_and_calibration(self, gain: Gain, sps: int) -> None:
        """Tare empty, calibrate with 2 kg, then a 4.2 kg payload reads 4.2 +- 0.05 kg."""
        async def main() -> tuple[float, float]:
            body, lines, hx = _rig(gain, sps)
            await hx.start()
            await _settle(hx, 5)
            await hx.tare()
            body.payload_kg = 2.0
            await _settle(hx)
            factor = await hx.calibrate(2.0)
            body.payload_kg = 4.2
            kg = await _settle(hx)
            await hx.close()
            assert lines.pulse_counts[-1] == gain.pulses
            return kg, factor

        kg, factor = vclock.run(main())
        assert abs(kg - 4.2) <= 0.05
        expected = 103_500.0 * (64 if gain is Gain.A64 else 128) / 128
        assert abs(factor / expected - 1) < 0.01

    def test_output_rate_follows_the_chip(self) -> None:
        """At 80 SPS the driver publishes about 80 readings a second; at 10 SPS about 10."""
        async def main(sps: int) -> int:
            _, _, hx = _rig(sps=sps)
            await hx.start()
            await _settle(hx, 3)
            before = hx.counts["accepted"]
            await asyncio.sleep(5)
            await hx.close()
            return hx.counts["accepted"] - before

        assert 390 <= vclock.run(main(80)) <= 410
        assert 48 <= vclock.run(main(10)) <= 52

    def test_glitched_read_is_discarded_and_readings_stay_right(self) -> None:
        """A clock pulse held 80 us powers the chip down: that read (and the settling one
        after the reset) are dropped and no wrong weight is ever published."""
        async def main() -> None:
            body, lines, hx = _rig()
            hx.tare_offset, hx.calibration_factor = -48_213, 103_500.0
            body.payload_kg = 3.0
            await hx.start()
            await _settle(hx, 10)
            lines.glitch_next_read(at_pulse=12)
            published = [(await hx.next_reading()).kg for _ in range(15)]
            await hx.close()
            assert hx.counts["sck_high"] == 1
            assert lines.power_downs == 1
            assert all(abs(kg - 3.0) < 0.02 for kg in published)

        vclock.run(main())

    def test_a_read_broken_off_mid_code_is_reset_and_reading_resumes(self) -> None:
        """A pulse the driver did not make (a reader stalled a whole conversion between two
        of its pulses) starts a read; DOUT then holds a 1 bit and never falls. The driver's
        timeout resets the chip (PD_SCK high over 60 us) and readings come again."""
        async def main() -> None:
            body, lines, hx = _rig()
            hx.tare_offset, hx.calibration_factor = -48_213, 103_500.0
            body.payload_kg = 2.0
            await hx.start()
            await _settle(hx, 3)
            lines.saturate(high=False)  # the code's first bit is a 1

            def stray_pulse() -> None:
                lines.pulse_sck()
                lines.clear_faults()

            lines.on_dout_low(stray_pulse)
            accepted = hx.counts["accepted"]
            await asyncio.sleep(3 * hx.timeout_s)
            assert hx.counts["timeouts"] >= 1
            assert lines.power_downs >= 1
            assert abs(await _settle(hx, 5) - 2.0) < 0.02
            assert hx.counts["accepted"] > accepted
            await hx.close()

        vclock.run(main())

    def test_saturated_input_publishes_nothing_until_it_recovers(self) -> None:
        """Saturated codes are counted and skipped; readings resume when the input is back."""
        async def main() -> None:
            _, lines, hx = _rig()
            await hx.start()
            await _settle(hx, 3)
            lines.saturate(high=True)
            published_before = hx.counts["accepted"]
            await asyncio.sleep(2)
            assert hx.counts["saturated"] >= 18
            assert hx.counts["accepted"] == published_before
            lines.clear_faults()
            await _settle(hx, 3)
            await hx.close()

        vclock.run(main())

    def test_a_single_spike_is_rejected_as_an_outlier(self) -> None:
        """One conversion 5 kg off the recent median never reaches the average."""
        async def main() -> None:
            body, lines, hx = _rig()
            hx.tare_offset, hx.calibration_factor = -48_213, 103_500.0
            body.payload_kg = 1.0
            await hx.start()
            await _settle(hx, 10)
            lines.spike_next_conversion(5 * 103_500)
            published = [(await hx.next_reading()).kg for _ in range(10)]
            await hx.close()
            assert hx.counts["outliers"] == 1
            assert all(abs(kg - 1.0) < 0.02 for kg in published)

        vclock.run(main())

    def test_a_real_step_in_load_is_followed(self) -> None:
        """A load that stays is accepted after half the median window, not rejected forever."""
        async def main() -> float:
            body, _, hx = _rig()
            hx.tare_offset, hx.calibration_factor = -48_213, 103_500.0
            await hx.start()
            await _settle(hx, 10)
            body.payload_kg = 6.0
            kg = await _settle(hx, 12)
            await hx.close()
            return kg

        assert abs(vclock.run(main()) - 6.0) < 0.02

    def test_no_data_ready_is_device_unavailable(self) -> None:
        """With DOUT disconnected (pulled high) start() fails with a clear message."""
        async def main() -> None:
            _, lines, hx = _rig()
            lines.disconnect()
            with pytest.raises(DeviceUnavailable, match="DOUT never went low"):
                await hx.start()

        vclock.run(main())

    def test_close_powers_the_chip_down(self) -> None:
        """close() leaves PD_SCK high, which powers the HX711 down."""
        async def main() -> bool:
            _, lines, hx = _rig()
            await hx.start()
            await _settle(hx, 2)
            await hx.close()
            await asyncio.sleep(0.01)
            return lines.powered_down

        assert vclock.run(main()) is True

    def test_calibrating_without_the_weight_is_refused(self) -> None:
        """Calibrating with nothing placed says so instead of storing a zero factor."""
        async def main() -> None:
            _, _, hx = _rig()
            await hx.start()
            await hx.tare()
            with pytest.raises(ValueError, match="changed by only"):
                await hx.calibrate(2.0)
            await hx.close()

        vclock.run(main())


class TestMedian:
    @given(st.lists(st.integers(-0x800000, 0x7FFFFF), min_size=1, max_size=9))
    def test_is_the_statistics_median(self, codes: list[int]) -> None:
        """The outlier filter's median is ``statistics.median``'s, value and type."""
        got, expected = _median(deque(codes)), statistics.median(codes)
        assert got == expected and type(got) is type(expected)


class TestHx711FromSettings:
    def test_built_from_the_hx711_section_and_tuned_live(self) -> None:
        """from_settings takes gain, rate, tare and factor; tuning them applies at once."""
        from drivers.hx711 import from_settings
        from robotd.config.loader import defaults
        from robotd.config.settings import Settings

        settings = Settings(defaults())
        settings.set("hx711.gain", "A64")
        settings.set("hx711.sps", 80)
        lines = SimHx711Lines(weight_kg=lambda: 0.0, sps=80)
        hx = from_settings(settings, open_lines=lambda: lines)
        assert (hx.gain, hx.period_s) == (Gain.A64, 1 / 80)
        settings.set("hx711.tare_offset", -1234)
        settings.set("hx711.calibration_factor", 51_750.0)
        settings.set("hx711.average_window", 4)
        assert (hx.tare_offset, hx.calibration_factor, hx.filter.window) == (-1234, 51_750.0, 4)
        assert hx.filter.outlier_counts == 51_750.0


class TestHx711Tare:
    def test_tare_with_only_saturated_reads_fails_clearly(self) -> None:
        """Taring while every read is saturated raises DeviceUnavailable instead of hanging."""
        async def main() -> None:
            _, lines, hx = _rig()
            await hx.start()
            lines.saturate()
            with pytest.raises(DeviceUnavailable, match="no good reading"):
                await hx.tare()
            await hx.close()
            with pytest.raises(DeviceUnavailable, match="not started"):
                await hx.tare()

        vclock.run(main())


class TestHx711TareAndCalibrationFaults:
    @pytest.mark.parametrize("settled", [1, 10])
    def test_a_spike_during_tare_does_not_move_the_zero(self, settled: int) -> None:
        """One conversion 2 M counts off while taring (right after start-up, when no median
        exists yet, or later) leaves the tare within noise of the true zero."""
        async def main() -> tuple[int, float]:
            _, lines, hx = _rig()
            hx.calibration_factor = 103_500.0
            await hx.start()
            await _settle(hx, settled)
            lines.spike_next_conversion(2_000_000)
            await hx.tare()
            kg = await _settle(hx, 10)
            await hx.close()
            return hx.tare_offset, kg

        tare, kg = vclock.run(main())
        assert tare == pytest.approx(-48_213, abs=300)
        assert abs(kg) < 0.01

    def test_calibrating_a_cell_wired_backwards_is_refused_with_advice(self) -> None:
        """A load that lowers the reading would need a negative factor, which robotd.toml
        refuses: calibrate() says to swap A+ and A- instead of returning it."""
        async def main() -> None:
            body, _, hx = _rig(counts_per_kg=-103_500.0)
            await hx.start()
            await hx.tare()
            body.payload_kg = 2.0
            with pytest.raises(ValueError, match="swap A\\+ and A-"):
                await hx.calibrate(2.0)
            await hx.close()

        vclock.run(main())

    @pytest.mark.parametrize("known_kg", [0.0, -2.0, float("nan"), float("inf")])
    def test_an_unusable_known_weight_is_refused(self, known_kg: float) -> None:
        """Zero, negative, NaN or infinite known weights raise before any factor is set."""
        async def main() -> None:
            _, _, hx = _rig()
            await hx.start()
            with pytest.raises(ValueError, match="known weight"):
                await hx.calibrate(known_kg)
            await hx.close()
            assert hx.calibration_factor == 107374.0

        vclock.run(main())

    @pytest.mark.parametrize("sps", [0, 40, 81])
    def test_a_rate_the_chip_cannot_run_at_is_refused(self, sps: int) -> None:
        """hx711.sps other than 10 or 80 (the config allows 10..80) is refused up front:
        the driver would pace its reads for a rate the chip never runs at."""
        with pytest.raises(ValueError, match="10 or 80 SPS"):
            Hx711(lambda: SimHx711Lines(weight_kg=lambda: 0.0), sps=sps)

    @pytest.mark.parametrize("factor", [0.0, float("nan"), float("inf")])
    def test_an_unusable_factor_is_refused(self, factor: float) -> None:
        """The constructor and set_calibration_factor refuse 0, NaN and infinity."""
        with pytest.raises(ValueError, match="calibration_factor"):
            Hx711(lambda: SimHx711Lines(weight_kg=lambda: 0.0), calibration_factor=factor)
        hx = _rig()[2]
        with pytest.raises(ValueError, match="calibration_factor"):
            hx.set_calibration_factor(factor)


class TestHx711LineErrors:
    def test_a_vanished_gpio_chip_is_reported_and_reading_resumes(self) -> None:
        """OSError from the lines (lgpio after the chip went away) does not end the reader:
        it is counted, named in status(), and readings resume once the lines answer; close()
        still works."""
        async def main() -> None:
            body, lines, hx = _rig()
            hx.tare_offset, hx.calibration_factor = -48_213, 103_500.0
            body.payload_kg = 2.0
            await hx.start()
            await _settle(hx, 3)
            lines.lose_gpio()
            await asyncio.sleep(3)
            status = hx.status()
            assert status["line_errors"] >= 2 and "No such device" in status["last_error"]
            assert status["running"] is True
            lines.restore_gpio()
            kg = await asyncio.wait_for(_settle(hx, 10), 10)
            await hx.close()
            assert abs(kg - 2.0) < 0.02

        vclock.run(main())

    def test_close_with_the_gpio_chip_gone_does_not_raise(self) -> None:
        """Stopping the daemon after the GPIO chip vanished still closes the driver."""
        async def main() -> bool:
            _, lines, hx = _rig()
            await hx.start()
            await _settle(hx, 2)
            lines.lose_gpio()
            await hx.close()
            return hx.status()["running"]

        assert vclock.run(main()) is False
