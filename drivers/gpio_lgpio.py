"""The HX711's GPIO lines on a Raspberry Pi through ``lgpio`` (the optional ``pi`` extra).

lgpio is imported only when the lines are opened, so installing and testing robotd never
needs it. On Raspberry Pi OS it also comes as the ``python3-lgpio`` package. The Pi 5's header
is ``/dev/gpiochip4`` on kernels before 6.6.45 and ``/dev/gpiochip0`` after.
"""

from __future__ import annotations

import asyncio
import contextlib
import threading
import time
from collections.abc import Callable
from typing import Any

from hal.devices import DeviceUnavailable


def _import_lgpio() -> Any:
    try:
        import lgpio
    except ImportError as exc:
        msg = ("hx711: the lgpio module is missing; install robotd with the pi extra "
               "(pip install 'robotd[pi]') or apt install python3-lgpio")
        raise DeviceUnavailable(msg) from exc
    return lgpio


class LgpioHx711Lines:
    """``hal.ports.Hx711Lines`` on ``/dev/gpiochipN``: PD_SCK an output, DOUT an input.

    DOUT is claimed as an alert line, so the lines also offer ``hal.ports.DoutAlert``: the
    driver sleeps until DOUT falls instead of polling it. DOUT also falls between a read's
    data bits; those alerts find no waiter, and lgpio's thread waits for the GIL, which a read
    holds for well under Python's 5 ms switch interval, so they cannot stretch a pulse.
    """

    def __init__(self, chip: int, data_gpio: int, clock_gpio: int,
                 lgpio_module: Any | None = None) -> None:
        self._lg = lgpio_module if lgpio_module is not None else _import_lgpio()
        self._clock = clock_gpio
        self._data = data_gpio
        self._waiters: list[tuple[asyncio.AbstractEventLoop, Callable[[], None]]] = []
        self._waiters_lock = threading.Lock()
        self._alert: Any = None
        try:
            self._handle = self._lg.gpiochip_open(chip)
        except Exception as exc:  # lgpio raises its own lgpio.error
            msg = f"hx711: cannot open /dev/gpiochip{chip} ({exc}); check the chip number"
            raise DeviceUnavailable(msg) from exc
        try:
            self._lg.gpio_claim_output(self._handle, clock_gpio, 0)
            self._lg.gpio_claim_alert(self._handle, data_gpio, self._lg.FALLING_EDGE)
            self._alert = self._lg.callback(self._handle, data_gpio, self._lg.FALLING_EDGE,
                                            self._on_alert)
        except Exception as exc:
            self._lg.gpiochip_close(self._handle)
            msg = (f"hx711: cannot claim GPIO {clock_gpio} (PD_SCK) and {data_gpio} (DOUT) on "
                   f"gpiochip{chip} ({exc}); is another program using them?")
            raise DeviceUnavailable(msg) from exc

    def set_sck(self, high: bool) -> None:
        self._lg.gpio_write(self._handle, self._clock, 1 if high else 0)

    def pulse_sck(self) -> int:
        """``hal.ports.SckPulse``: PD_SCK high then low; its high time as ``now_us`` gives it
        (fewer Python calls between the edges than set_sck twice: a shorter pulse)."""
        write, handle, clock = self._lg.gpio_write, self._handle, self._clock
        t0_us = time.monotonic_ns() // 1000
        write(handle, clock, 1)
        write(handle, clock, 0)
        return time.monotonic_ns() // 1000 - t0_us

    def pulse_sck_read(self) -> tuple[int, bool]:
        """``hal.ports.SckPulse``: ``pulse_sck()``, then DOUT read."""
        high_us = self.pulse_sck()
        return high_us, self.read_dout()

    def read_dout(self) -> bool:
        return bool(self._lg.gpio_read(self._handle, self._data))

    def on_dout_low(self, callback: Callable[[], None]) -> Callable[[], None]:
        """``hal.ports.DoutAlert``: ``callback()`` on the running loop at DOUT's next fall."""
        loop = asyncio.get_running_loop()
        entry = (loop, callback)
        with self._waiters_lock:
            self._waiters.append(entry)
        if not self.read_dout():  # it fell before the alert was armed: no edge will come
            self._on_alert(0, self._data, 0, 0)

        def cancel() -> None:
            with self._waiters_lock:
                if entry in self._waiters:
                    self._waiters.remove(entry)

        return cancel

    def _on_alert(self, _chip: int, _gpio: int, level: int, _timestamp_ns: int) -> None:
        """lgpio's thread (its callback API calls from its own thread): hand the waiters over
        to their loops with ``call_soon_threadsafe``; nothing else happens here."""
        if level != 0:  # only falls; 2 is lgpio's watchdog report
            return
        with self._waiters_lock:
            waiters, self._waiters = self._waiters, []
        for loop, callback in waiters:
            with contextlib.suppress(RuntimeError):  # the loop closed while we shut down
                loop.call_soon_threadsafe(callback)

    def now_us(self) -> int:
        # Pulse widths are measured within one synchronous read, where the event loop's clock
        # stands still; a monotonic hardware clock is the only one that moves.
        return time.monotonic_ns() // 1000

    def close(self) -> None:
        if self._handle is None:
            return
        handle, self._handle = self._handle, None
        alert, self._alert = self._alert, None
        if alert is not None:
            with contextlib.suppress(Exception):  # closing anyway
                alert.cancel()
        for gpio in (self._clock, self._data):
            with contextlib.suppress(Exception):  # closing anyway
                self._lg.gpio_free(handle, gpio)
        self._lg.gpiochip_close(handle)


def lgpio_lines_opener(chip: int, data_gpio: int, clock_gpio: int) -> Callable[[], LgpioHx711Lines]:
    """What ``drivers.hx711.Hx711`` takes as ``open_lines`` on a Pi."""
    return lambda: LgpioHx711Lines(chip, data_gpio, clock_gpio)
