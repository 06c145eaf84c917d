"""HX711 load-cell ADC, bit-banged through ``hal.ports.Hx711Lines``.

Protocol (Avia HX711 datasheet): DOUT goes low when a conversion is ready; each PD_SCK pulse
shifts out one bit, MSB first, 24 bits of two's complement; 1, 2 or 3 extra pulses (25/26/27 in
total) select channel A gain 128, channel B gain 32 or channel A gain 64 for the NEXT
conversion. PD_SCK held high for more than 60 us powers the chip down, so a read during which
any pulse stayed high that long is discarded. The clocking is synchronous (microsecond timing
cannot yield to the event loop); the wait for data-ready is asynchronous
(``drivers.hx711_ready``: on DOUT's falling edge when the lines report it, else polled).

Filtering (seed 000 section 11): saturated codes rejected, a reading far from the median of
the recent ones rejected, then a moving average; kg = (average - tare_offset) / factor.
"""

from __future__ import annotations

import asyncio
import gc
import math
from collections.abc import Callable
from enum import Enum
from typing import Any

import structlog

from drivers.hx711_config import Hx711Config
from drivers.hx711_filter import OutlierFilter
from drivers.hx711_ready import wait_dout_low
from hal.devices import DeviceUnavailable
from hal.latest import LatestValue
from hal.ports import Hx711Lines
from hal.readings import WeightReading
from hal.settings import SettingsView
from hal.tasks import cancel_and_wait

log = structlog.get_logger(__name__)

MAX_SCK_HIGH_US = 60  # HX711: PD_SCK high for > 60 us enters power-down
RESET_HOLD_S = 100e-6  # PD_SCK held high this long to reset a stuck chip (> 60 us)
SATURATED_HIGH = 0x7FFFFF
SATURATED_LOW = -0x800000
MIN_CALIBRATION_COUNTS = 1000  # a calibration mass must move the code well above the noise


class Gain(Enum):
    """Channel and gain, with the total number of clock pulses per read that selects it."""

    A128 = 25
    B32 = 26
    A64 = 27

    @property
    def pulses(self) -> int:
        return self.value


class ReadDiscarded(Exception):
    """A read whose bits cannot be trusted; ``reason`` says why."""

    def __init__(self, reason: str, detail: str = "") -> None:
        super().__init__(f"{reason}: {detail}" if detail else reason)
        self.reason = reason


def to_signed24(raw: int) -> int:
    """Two's complement of a 24-bit code."""
    raw &= 0xFFFFFF
    return raw - (1 << 24) if raw & 0x800000 else raw


def clock_out(lines: Hx711Lines, gain: Gain) -> int:
    """Shift one conversion out (DOUT must already be low); returns the signed code.

    Raises ReadDiscarded("sck_high") when a pulse stayed high beyond 60 us, and
    ReadDiscarded("saturated") for the codes the chip gives when the input is out of range.
    """
    # The hot loop of a read: the line methods bound once, no call but theirs per pulse, and
    # one call per bit where the lines offer it (hal.ports.SckPulse).
    pulse_sck = getattr(lines, "pulse_sck", None) or _pulse_by_edges(lines)
    pulse_sck_read = (getattr(lines, "pulse_sck_read", None)
                      or _pulse_then_read(pulse_sck, lines.read_dout))
    raw = 0
    longest_us = 0
    for _ in range(24):
        # DOUT changes on the rising edge and holds until the next one: read after the pulse.
        high_us, bit = pulse_sck_read()
        longest_us = high_us if high_us > longest_us else longest_us  # max(), no call
        raw = (raw << 1) | bit
    for _ in range(gain.value - 24):  # the gain pulses: no data
        high_us = pulse_sck()
        longest_us = high_us if high_us > longest_us else longest_us
    if longest_us > MAX_SCK_HIGH_US:
        raise ReadDiscarded("sck_high", f"a clock pulse lasted {longest_us} us")
    code = to_signed24(raw)
    if code in (SATURATED_HIGH, SATURATED_LOW):
        raise ReadDiscarded("saturated", f"code {raw:06X}")
    return code


def _pulse_by_edges(lines: Hx711Lines) -> Callable[[], int]:
    """``SckPulse.pulse_sck`` for lines without it: PD_SCK high then low, its high time."""
    set_sck, now_us = lines.set_sck, lines.now_us

    def pulse_sck() -> int:
        t0 = now_us()
        set_sck(True)
        set_sck(False)
        return now_us() - t0

    return pulse_sck


def _pulse_then_read(pulse_sck: Callable[[], int],
                     read_dout: Callable[[], bool]) -> Callable[[], tuple[int, bool]]:
    """``SckPulse.pulse_sck_read`` for lines without it."""
    def pulse_sck_read() -> tuple[int, bool]:
        high_us = pulse_sck()
        return high_us, read_dout()

    return pulse_sck_read


class Hx711:
    """``hal.devices.LoadCell`` on an HX711.

    Args:
        open_lines: opens the two GPIO lines (raises DeviceUnavailable when it cannot).
        gain: channel and gain; sps: the rate the RATE pin selects (10 or 80).
        tare_offset: raw code of the empty bin; calibration_factor: raw counts per kg.
    """

    def __init__(self, open_lines: Callable[[], Hx711Lines], *, name: str = "hx711",
                 gain: Gain = Gain.A128, sps: int = 10, tare_offset: int = 0,
                 calibration_factor: float = 107374.0, average_window: int = 8,
                 median_window: int = 5, outlier_kg: float = 1.0,
                 timeout_s: float = 1.0) -> None:
        if sps not in (10, 80):
            msg = f"hx711.sps: the HX711's RATE pin selects 10 or 80 SPS, got {sps}"
            raise ValueError(msg)
        if calibration_factor == 0 or not math.isfinite(calibration_factor):
            msg = ("hx711.calibration_factor must be a finite number other than 0, "
                   f"got {calibration_factor}")
            raise ValueError(msg)
        self.name = name
        self._open_lines = open_lines
        self.gain = gain
        self.period_s = 1.0 / sps
        self.tare_offset = tare_offset
        self.calibration_factor = calibration_factor
        self.timeout_s = timeout_s
        self._outlier_kg = outlier_kg
        self.filter = OutlierFilter(median_window, average_window,
                                    outlier_kg * abs(calibration_factor))
        self._lines: Hx711Lines | None = None
        self._task: asyncio.Task[None] | None = None
        self._settle_timer: asyncio.TimerHandle | None = None
        self._latest: LatestValue[WeightReading] = LatestValue()
        self._discard_next = 1
        self.counts = dict.fromkeys(("reads", "accepted", "sck_high", "saturated", "outliers",
                                     "timeouts", "settling", "line_errors"), 0)
        self.last_error: str | None = None

    # --- LoadCell ---------------------------------------------------------------------------
    async def start(self) -> None:
        if self._task is not None:
            return
        try:
            self._lines = self._open_lines()
        except OSError as exc:
            msg = f"{self.name}: cannot open the GPIO lines ({exc})"
            raise DeviceUnavailable(msg) from exc
        self._lines.set_sck(False)  # power up (PD_SCK low)
        self._discard_next = 1
        if not await self._wait_ready(max(self.timeout_s, 4 * self.period_s)):
            await self.close()
            msg = (f"{self.name}: DOUT never went low (no conversion ready); check power, "
                   "wiring and the data/clock GPIO numbers")
            raise DeviceUnavailable(msg)
        self._task = asyncio.create_task(self._run(), name=f"{self.name}.reader")

    async def close(self) -> None:
        """Stop reading and power the chip down; safe to call twice."""
        task, self._task = self._task, None
        await cancel_and_wait(task)
        lines, self._lines = self._lines, None
        if lines is None:
            return
        try:
            lines.set_sck(True)  # leave it powered down
        except Exception as exc:  # the GPIO chip is gone: nothing left to power down
            log.warning("hx711.power_down_failed", error=f"{type(exc).__name__}: {exc}")
        close = getattr(lines, "close", None)
        if callable(close):
            close()

    def latest(self) -> WeightReading | None:
        return self._latest.latest()

    async def next_reading(self) -> WeightReading:
        return await self._latest.next()

    async def tare(self) -> None:
        """Make the current load zero: a fresh moving-average window becomes ``tare_offset``."""
        self.tare_offset = round(await self.average_raw())
        log.info("hx711.tared", tare_offset=self.tare_offset)

    async def calibrate(self, known_kg: float) -> float:
        """With ``known_kg`` on the tared cell, set and return the counts per kg."""
        if not (known_kg > 0 and math.isfinite(known_kg)):
            msg = f"known weight must be a number of kg > 0, got {known_kg}"
            raise ValueError(msg)
        change = await self.average_raw() - self.tare_offset
        if abs(change) < MIN_CALIBRATION_COUNTS:
            msg = (f"the reading changed by only {change:.0f} counts with the known weight; "
                   "is it on the cell?")
            raise ValueError(msg)
        if change < 0:
            # hx711.calibration_factor must be > 0 in robotd.toml, so a negative one cannot
            # be kept; the wiring is what needs changing.
            msg = (f"the reading went down by {-change:.0f} counts with the known weight on: "
                   "the load cell's signal wires (A+/A-, usually green and white) are swapped "
                   "or the cell is mounted upside down; swap A+ and A- and calibrate again")
            raise ValueError(msg)
        factor = change / known_kg
        self.set_calibration_factor(factor)
        log.info("hx711.calibrated", calibration_factor=round(factor, 3), known_kg=known_kg)
        return factor

    def set_calibration_factor(self, factor: float) -> None:
        if factor == 0 or not math.isfinite(factor):
            msg = f"hx711.calibration_factor must be a finite number other than 0, got {factor}"
            raise ValueError(msg)
        self.calibration_factor = factor
        self.filter.outlier_counts = self._outlier_kg * abs(factor)

    async def average_raw(self) -> float:
        """Mean raw code over a fresh, full moving-average window.

        Raises DeviceUnavailable when the driver is not running or readings stop coming
        (every read discarded: saturated input, a glitching clock line).
        """
        if self._task is None:
            msg = f"{self.name}: not started"
            raise DeviceUnavailable(msg)
        self.filter.clear()
        wait_s = self.timeout_s + 10 * self.period_s
        for _ in range(self.filter.window):
            try:
                reading = await asyncio.wait_for(self.next_reading(), wait_s)
            except TimeoutError:
                msg = (f"{self.name}: no good reading for {wait_s:g} s "
                       f"(discarded so far: {self.counts})")
                raise DeviceUnavailable(msg) from None
        average = self.filter.robust_average()
        return float(reading.raw) if average is None else average

    def status(self) -> dict[str, Any]:
        latest = self.latest()
        return {**self.counts, "kg": None if latest is None else round(latest.kg, 3),
                "raw": None if latest is None else latest.raw, "gain": self.gain.name,
                "tare_offset": self.tare_offset,
                "calibration_factor": round(self.calibration_factor, 3),
                "running": self._task is not None, "last_error": self.last_error}

    # --- reading ----------------------------------------------------------------------------
    async def _wait_ready(self, timeout_s: float) -> bool:
        assert self._lines is not None
        return await wait_dout_low(self._lines, timeout_s)

    def read_once(self) -> int:
        """Clock out one conversion (DOUT low); raises ReadDiscarded."""
        assert self._lines is not None
        self.counts["reads"] += 1
        # A garbage collection in the middle of a pulse would hold PD_SCK high past 60 us.
        gc_was_on = gc.isenabled()
        gc.disable()
        try:
            return clock_out(self._lines, self.gain)
        finally:
            if gc_was_on:
                gc.enable()

    async def _run(self) -> None:
        from_s: float | None = None  # when to look at DOUT next (None: at once)
        try:
            while True:
                try:
                    from_s = await self._read_next(from_s)
                except Exception as exc:  # lgpio.error, OSError: the GPIO chip went away
                    self.counts["line_errors"] += 1
                    self.last_error = f"{type(exc).__name__}: {exc}"
                    log.warning("hx711.line_error", error=self.last_error,
                                retry_s=self.timeout_s)
                    from_s = None
                    await asyncio.sleep(self.timeout_s)
        finally:
            if self._settle_timer is not None:  # stopped: the read in hand is not published
                self._settle_timer.cancel()
                self._settle_timer = None

    async def _read_next(self, from_s: float | None) -> float | None:
        """Wait for one conversion (DOUT read first at ``from_s``) and read it; its weight is
        published 80 % of a conversion period later. Returns when to look at DOUT next."""
        assert self._lines is not None
        if not await wait_dout_low(self._lines, self.timeout_s, from_s=from_s):
            self.counts["timeouts"] += 1
            log.warning("hx711.timeout", waited_s=self.timeout_s)
            await self._reset_chip()
            return None
        code: int | None = None
        try:
            code = self.read_once()
        except ReadDiscarded as exc:
            self.counts[exc.reason] += 1
            log.info("hx711.discarded", reason=exc.reason, detail=str(exc))
            if exc.reason == "sck_high":
                # The chip reset on power-down: it is back on A128 and settling.
                self._discard_next = 1
        # Sleep through most of the next conversion instead of polling for it. The reading
        # is filtered and published then, from a loop timer: the task itself waits on for
        # DOUT from that instant without waking in between (one wake-up per read, not three).
        loop = asyncio.get_running_loop()
        settle_s = loop.time() + self.period_s * 0.8
        if code is not None:
            self._settle_timer = loop.call_at(settle_s, self._settle, code)
        return settle_s

    async def _reset_chip(self) -> None:
        """HX711: a read broken off (the reader stalled a whole conversion period between
        two pulses, so the chip took the next pulse as a new read's first) leaves DOUT
        holding a data bit, high for good if that bit is 1. PD_SCK held high over 60 us
        powers the chip down and low again resets it: it settles and converts anew (on A/128:
        the first read after it is dropped)."""
        assert self._lines is not None
        self._lines.set_sck(True)
        await asyncio.sleep(RESET_HOLD_S)
        self._lines.set_sck(False)
        self._discard_next = 1

    def _settle(self, code: int) -> None:
        """A read's code, a conversion period after the read: filter it, publish the weight."""
        self._settle_timer = None
        if self._discard_next:
            # The gain pulses of this read apply from the next conversion on.
            self._discard_next -= 1
            self.counts["settling"] += 1
            return
        if not self.filter.add(code):
            self.counts["outliers"] += 1
            return
        self.counts["accepted"] += 1
        average = self.filter.average()
        assert average is not None
        kg = (average - self.tare_offset) / self.calibration_factor
        t_s = asyncio.get_running_loop().time()
        self._latest.publish(WeightReading(kg=kg, raw=round(average), t_s=t_s))

    def apply_setting(self, dotted: str, value: Any) -> None:
        """A tuned ``hx711.*`` value takes effect at once (tare, factor, windows)."""
        key = dotted.rpartition(".")[2]
        if key == "tare_offset":
            self.tare_offset = int(value)
        elif key == "calibration_factor":
            self.set_calibration_factor(float(value))
        elif key == "average_window":
            self.filter.resize(int(value))
        elif key == "outlier_kg":
            self._outlier_kg = float(value)
            self.filter.outlier_counts = self._outlier_kg * abs(self.calibration_factor)


def from_settings(settings: SettingsView,
                  open_lines: Callable[[], Hx711Lines] | None = None) -> Hx711:
    """The load cell from the ``hx711`` section, on lgpio unless ``open_lines`` is given."""
    config = Hx711Config.from_settings(settings)
    if open_lines is None and config.source == "stream":
        from drivers.hx711_stream import StreamHx711Lines

        if not config.stream:
            msg = "hx711.stream: empty, but hx711.source = 'stream' needs a pipe"
            raise ValueError(msg)
        path = config.stream

        def open_lines() -> Hx711Lines:
            return StreamHx711Lines(path, asyncio.get_running_loop())

    if open_lines is None:
        from drivers.gpio_lgpio import lgpio_lines_opener

        open_lines = lgpio_lines_opener(config.gpiochip, config.data_gpio, config.clock_gpio)
    hx = Hx711(open_lines, gain=Gain[config.gain], sps=config.sps,
               tare_offset=config.tare_offset, calibration_factor=config.calibration_factor,
               average_window=config.average_window, median_window=config.median_window,
               outlier_kg=config.outlier_kg, timeout_s=config.timeout_s)
    settings.watch("hx711", hx.apply_setting)
    return hx
