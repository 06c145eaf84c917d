"""A simulated HX711 that answers clock pulses bit by bit (a ``hal.ports.Hx711Lines``).

The chip converts at its output rate (10 or 80 SPS) after a settling time; DOUT goes low when
a conversion is ready, each rising edge of PD_SCK shifts out the next bit (MSB first) of the
24-bit two's-complement code, and the pulses after the 24th choose channel and gain for the
next conversion (25: A/128, 26: B/32, 27: A/64). PD_SCK held high for more than 60 us powers
it down; bringing it low again resets it to A/128 and restarts settling. The code is
``offset + counts_per_kg * gain/128 * payload + noise``, clamped to the 24-bit range.

Microseconds: the port keeps its own clock that advances a little with every call (the time
a GPIO access takes) and never falls behind the event loop's clock. ``on_dout_low``
(``hal.ports.DoutAlert``) calls back when a conversion completes, from a timer on the loop's
clock (``clock`` must then be the running loop's time, as by default).
"""

from __future__ import annotations

import asyncio
import errno
import math
import os
import random
from collections.abc import Callable
from dataclasses import dataclass, field

from sim.world.body import DiffDriveBody

POWER_DOWN_US = 60
CODE_MAX = 0x7FFFFF
CODE_MIN = -0x800000
GAIN_BY_PULSES = {25: ("A", 128), 26: ("B", 32), 27: ("A", 64)}
# The bits of each byte, MSB first: a code's 24 DOUT levels are three lookups.
_BYTE_BITS = tuple(tuple(bool((byte >> (7 - i)) & 1) for i in range(8)) for byte in range(256))


def _loop_s_reaching(us: int) -> float:
    """The earliest clock reading (seconds, >= 0) whose ``int(s * 1e6)`` is ``us`` or more."""
    s = max(0.0, us / 1_000_000)  # the loop's clock does not go below zero
    while int(s * 1_000_000) < us:
        s = math.nextafter(s, math.inf)
    while s > 0.0 and int((earlier := math.nextafter(s, -math.inf)) * 1_000_000) >= us:
        s = earlier
    return s


def _loop_clock() -> float:
    try:
        return asyncio.get_running_loop().time()
    except RuntimeError:
        return 0.0


@dataclass
class SimHx711Lines:
    """Bit-level HX711 on a load cell carrying ``weight_kg()``.

    Args:
        weight_kg: the load on the cell now (``SimHx711Lines.on_body`` uses the payload).
        sps: output data rate (10 or 80).
        offset_counts, counts_per_kg: the cell's zero and scale at channel A, gain 128.
        noise_counts: Gaussian noise of one conversion.
        call_us: how long one GPIO access takes.
        settle_conversions: conversions skipped after power-up/reset before DOUT goes low.
    """

    weight_kg: Callable[[], float]
    sps: int = 10
    offset_counts: int = -48_213
    counts_per_kg: float = 103_500.0
    noise_counts: float = 150.0
    rng: random.Random = field(default_factory=lambda: random.Random(1))
    clock: Callable[[], float] = _loop_clock
    call_us: int = 1
    settle_conversions: int = 4
    # what happened, for tests
    pulses_total: int = 0
    reads_started: int = 0
    reads_completed: int = 0
    power_downs: int = 0
    pulse_counts: list[int] = field(default_factory=list)
    _now_us: int = 0
    _sck: bool = False
    _rise_us: int = 0
    _pulses_per_read: int = 25
    _pulses: int = 0
    _bits: tuple[bool, ...] = (True,) * 25  # DOUT after rising edge n: _bits[n], n = 1..24
    _first_ready_us: int = 0
    _last_read_index: int = -1
    _glitch: tuple[int, int] | None = None
    _saturate: int | None = None
    _spike_counts: int = 0
    _connected: bool = True
    _gpio_error: OSError | None = None
    _clock_s: float = -1.0
    _clock_us: int = 0
    _dout_waiters: list[Callable[[], None]] = field(default_factory=list)
    _dout_timer: asyncio.Handle | None = None

    def __post_init__(self) -> None:
        if self.sps not in (10, 80):
            msg = f"HX711 output rate is 10 or 80 SPS, got {self.sps}"
            raise ValueError(msg)
        self._now_us = self._loop_us()
        self._first_ready_us = self._now_us + self.settle_conversions * self.period_us

    @classmethod
    def on_body(cls, body: DiffDriveBody, **kwargs: object) -> SimHx711Lines:
        """A load cell under the body's bin: it weighs ``body.payload_kg``."""
        return cls(weight_kg=lambda: body.payload_kg, **kwargs)  # type: ignore[arg-type]

    @property
    def period_us(self) -> int:
        return 1_000_000 // self.sps

    # --- fault switches ----------------------------------------------------------------------
    def glitch_next_read(self, at_pulse: int = 10, high_us: int = 80) -> None:
        """During the next read, pulse ``at_pulse`` stays high ``high_us`` (a preempted task)."""
        self._glitch = (at_pulse, high_us)

    def saturate(self, high: bool = True) -> None:
        """The input is out of range: conversions give 0x7FFFFF (or 0x800000)."""
        self._saturate = CODE_MAX if high else CODE_MIN

    def spike_next_conversion(self, counts: int) -> None:
        """The next conversion is off by ``counts`` (interference on the bridge wires)."""
        self._spike_counts = counts

    def disconnect(self) -> None:
        """DOUT wire off: the input's pull-up holds it high, so no conversion looks ready."""
        self._connected = False

    def connect(self) -> None:
        self._connected = True
        if self._dout_waiters:
            self._arm_dout_alert()

    def lose_gpio(self, errno_name: str = "ENODEV") -> None:
        """The GPIO chip went away (a header cable pulled, a driver unloaded): every line
        access raises OSError, as lgpio does, until ``restore_gpio``."""
        code = getattr(errno, errno_name)
        self._gpio_error = OSError(code, os.strerror(code))
        if self._dout_waiters:
            self._arm_dout_alert()  # the reader finds out at its next access

    def restore_gpio(self) -> None:
        self._gpio_error = None

    def clear_faults(self) -> None:
        self._glitch = None
        self._saturate = None
        self._spike_counts = 0

    @property
    def powered_down(self) -> bool:
        now_us = max(self._now_us, self._loop_us())
        return self._sck and now_us - self._rise_us > POWER_DOWN_US

    @property
    def gain(self) -> tuple[str, int]:
        return GAIN_BY_PULSES.get(self._pulses_per_read, ("A", 128))

    # --- Hx711Lines --------------------------------------------------------------------------
    # The driver makes ~50 of these calls per conversion, all within one instant of the loop's
    # clock: each works out the port's microseconds itself (``_tick``, inlined: a Python call
    # less per access) and the loop's microseconds once per instant.
    def now_us(self) -> int:
        return self._tick()

    def read_dout(self) -> bool:
        if self._gpio_error is not None:
            raise self._gpio_error
        clock_s = self.clock()  # _tick, inlined
        if clock_s != self._clock_s:
            self._clock_s = clock_s
            self._clock_us = int(clock_s * 1_000_000)
        now = self._now_us + self.call_us
        clock_us = self._clock_us
        self._now_us = now = now if now > clock_us else clock_us
        # ``powered_down`` with the time just taken (the clock cannot move in between).
        if (self._sck and now - self._rise_us > POWER_DOWN_US) or not self._connected:
            return True
        pulses = self._pulses
        if 1 <= pulses <= 24:
            return self._bits[pulses]
        return not self._ready(now)

    def set_sck(self, high: bool) -> None:
        if self._gpio_error is not None:
            raise self._gpio_error
        now = self._tick()
        if high == self._sck:
            return
        self._sck = high
        if high:
            pulses = self._pulses
            if 1 <= pulses < 23 and self._glitch is None:
                # Within the 24 data bits: the next bit is on DOUT already.
                self._rise_us = now
                self.pulses_total += 1
                self._pulses = pulses + 1
                return
            self._rise(now)
            return
        if now - self._rise_us > POWER_DOWN_US:
            self._reset(now)
        if self._dout_waiters:
            self._arm_dout_alert()

    def pulse_sck(self) -> int:
        """``hal.ports.SckPulse``: what ``now_us``, ``set_sck(True)``, ``set_sck(False)``,
        ``now_us`` do, in one call: PD_SCK's high time on the port's clock."""
        call_us = self.call_us
        if self._gpio_error is not None or self._sck or call_us < 0:
            t0_us = self._tick()
            self.set_sck(True)
            self.set_sck(False)
            return self._tick() - t0_us
        # Four accesses call_us apart (the loop's clock cannot move within the call).
        t0_us = self._first_access_us(call_us)
        rise_us = t0_us + call_us
        pulses = self._pulses
        if 1 <= pulses < 24 and self._glitch is None:
            # A data bit (set_sck's fast case): the next bit is on DOUT already.
            self._rise_us = rise_us
            self.pulses_total += 1
            self._pulses = pulses + 1
            if pulses == 23:
                self.reads_completed += 1
            fall_us = rise_us + call_us
        else:
            self._now_us = rise_us
            self._sck = True
            self._rise(rise_us)
            self._sck = False
            fall_us = self._now_us + call_us  # a glitch moves the port's clock on
        self._now_us = fall_us
        if fall_us - self._rise_us > POWER_DOWN_US:
            self._reset(fall_us)
        if self._dout_waiters:
            self._arm_dout_alert()
        self._now_us = fall_us + call_us
        return fall_us + call_us - t0_us

    def pulse_sck_read(self) -> tuple[int, bool]:
        """``hal.ports.SckPulse``: ``pulse_sck()`` then ``read_dout()``, in one call."""
        call_us = self.call_us
        pulses = self._pulses
        if (not 1 <= pulses < 24 or self._glitch is not None or self._gpio_error is not None
                or self._sck or self._dout_waiters or not self._connected
                or not 0 <= call_us <= POWER_DOWN_US):
            high_us = self.pulse_sck()
            return high_us, self.read_dout()
        # A data bit: five accesses call_us apart, the bit on DOUT after it.
        t0_us = self._first_access_us(call_us)
        self._rise_us = t0_us + call_us
        self.pulses_total += 1
        self._pulses = pulses = pulses + 1
        if pulses == 24:
            self.reads_completed += 1
        self._now_us = t0_us + 4 * call_us
        return 3 * call_us, self._bits[pulses]

    def on_dout_low(self, callback: Callable[[], None]) -> Callable[[], None]:
        """``hal.ports.DoutAlert``: ``callback()`` once DOUT reads low (a loop timer).

        The timer is due at the first loop time at which a read finds DOUT low: when the
        conversion completes."""
        self._dout_waiters.append(callback)
        self._arm_dout_alert()

        def cancel() -> None:
            if callback in self._dout_waiters:
                self._dout_waiters.remove(callback)
            if not self._dout_waiters and self._dout_timer is not None:
                self._dout_timer.cancel()
                self._dout_timer = None

        return cancel

    # --- the chip ----------------------------------------------------------------------------
    def _first_access_us(self, call_us: int) -> int:
        """The next access: call_us after the port's clock, not before the loop's."""
        clock_s = self.clock()
        if clock_s != self._clock_s:
            self._clock_s = clock_s
            self._clock_us = int(clock_s * 1_000_000)
        t0_us = self._now_us + call_us
        clock_us = self._clock_us
        return t0_us if t0_us > clock_us else clock_us  # max(), no call

    def _loop_us(self) -> int:
        return int(self.clock() * 1_000_000)

    def _tick(self) -> int:
        self._now_us = now_us = self._first_access_us(self.call_us)
        return now_us

    def _dout_falls_us(self) -> int | None:
        """When DOUT next reads low if the lines are left alone (now: it does, or an access
        raises); None: not before something changes (SCK, the wire)."""
        if self._gpio_error is not None:
            return self._now_us
        if not self._connected or self._sck:
            return None
        if 1 <= self._pulses <= 24:  # a read broken off: DOUT holds the bit
            return None if self._bits[self._pulses] else self._now_us
        return self._first_ready_us + (self._last_read_index + 1) * self.period_us

    def _arm_dout_alert(self) -> None:
        if self._dout_timer is not None:
            self._dout_timer.cancel()
            self._dout_timer = None
        falls_us = self._dout_falls_us()
        if falls_us is None:
            return
        loop = asyncio.get_running_loop()
        # An access reads the later of (this port's microseconds + one call) and the loop's
        # clock in whole microseconds: the first loop time at which one can find DOUT low.
        at_s = None if self._now_us + self.call_us >= falls_us else _loop_s_reaching(falls_us)
        if at_s is None or at_s <= loop.time():
            self._dout_timer = loop.call_soon(self._fire_dout_low)
        else:
            self._dout_timer = loop.call_at(at_s, self._fire_dout_low)

    def _fire_dout_low(self) -> None:
        self._dout_timer = None
        waiters, self._dout_waiters = self._dout_waiters, []
        for callback in waiters:
            callback()

    def _conversion_index(self, now_us: int) -> int:
        if now_us < self._first_ready_us:
            return -1
        return (now_us - self._first_ready_us) // self.period_us

    def _ready(self, now_us: int) -> bool:
        return self._conversion_index(now_us) > self._last_read_index

    def _rise(self, now_us: int) -> None:
        self._rise_us = now_us
        self.pulses_total += 1
        pulses = self._pulses
        if pulses == 0 or pulses >= 24:
            # _conversion_index and _ready, worked out once (nothing here changes them)
            first_us = self._first_ready_us
            index = -1 if now_us < first_us else (now_us - first_us) // (1_000_000 // self.sps)
            ready = index > self._last_read_index
            if pulses and ready:
                self._finish_read()
                pulses = 0
            if not pulses:
                if not ready:
                    return  # a stray pulse while no data is ready: ignored
                self._last_read_index = index
                code = self._code() & 0xFFFFFF
                self._bits = ((True,) + _BYTE_BITS[code >> 16] + _BYTE_BITS[(code >> 8) & 0xFF]
                              + _BYTE_BITS[code & 0xFF])
                self.reads_started += 1
        self._pulses = pulses = pulses + 1
        if pulses in GAIN_BY_PULSES:
            self._pulses_per_read = pulses  # the chip counts them as they come
        if pulses == 24:
            self.reads_completed += 1
        if self._glitch is not None and pulses == self._glitch[0]:
            self._now_us += self._glitch[1]
            self._glitch = None

    def _finish_read(self) -> None:
        self.pulse_counts.append(self._pulses)
        self._pulses = 0

    def _reset(self, now_us: int) -> None:
        """PD_SCK went low after a power-down: the chip restarts on A/128 and settles."""
        self.power_downs += 1
        if self._pulses:
            self.pulse_counts.append(self._pulses)
        self._pulses = 0
        self._pulses_per_read = 25
        self._first_ready_us = now_us + self.settle_conversions * self.period_us
        self._last_read_index = -1

    def _code(self) -> int:
        if self._saturate is not None:
            return self._saturate
        channel, gain = self.gain
        signal = self.counts_per_kg * gain / 128 * self.weight_kg() if channel == "A" else 0.0
        code = (self.offset_counts * gain / 128 + signal + self._spike_counts
                + self.rng.gauss(0, self.noise_counts))
        self._spike_counts = 0
        return _clamp_code(code)


def _clamp_code(code: float) -> int:
    """The 24-bit code for a conversion's value: floored, clipped to the chip's range; a
    value that is not a number (a load that is not one) reads as out of range, high."""
    # Comparisons rather than math.isnan, max() and min(): once per conversion, in the sim's
    # hot path. NaN fails the first comparison.
    if code < CODE_MAX:
        return math.floor(code) if code >= CODE_MIN + 1 else CODE_MIN
    return CODE_MAX
