"""The HX711's GPIO lines on a Raspberry Pi through ``lgpio`` (the optional ``pi`` extra).

lgpio is imported only when the lines are opened, so installing and testing robotd never
needs it. On Raspberry Pi OS it also comes as the ``python3-lgpio`` package. The Pi 5's header
is ``/dev/gpiochip4`` on kernels before 6.6.45 and ``/dev/gpiochip0`` after.
"""

from __future__ import annotations

import contextlib
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
    """``hal.ports.Hx711Lines`` on ``/dev/gpiochipN``: PD_SCK an output, DOUT an input."""

    def __init__(self, chip: int, data_gpio: int, clock_gpio: int,
                 lgpio_module: Any | None = None) -> None:
        self._lg = lgpio_module if lgpio_module is not None else _import_lgpio()
        self._clock = clock_gpio
        self._data = data_gpio
        try:
            self._handle = self._lg.gpiochip_open(chip)
        except Exception as exc:  # lgpio raises its own lgpio.error
            msg = f"hx711: cannot open /dev/gpiochip{chip} ({exc}); check the chip number"
            raise DeviceUnavailable(msg) from exc
        try:
            self._lg.gpio_claim_output(self._handle, clock_gpio, 0)
            self._lg.gpio_claim_input(self._handle, data_gpio)
        except Exception as exc:
            self._lg.gpiochip_close(self._handle)
            msg = (f"hx711: cannot claim GPIO {clock_gpio} (PD_SCK) and {data_gpio} (DOUT) on "
                   f"gpiochip{chip} ({exc}); is another program using them?")
            raise DeviceUnavailable(msg) from exc

    def set_sck(self, high: bool) -> None:
        self._lg.gpio_write(self._handle, self._clock, 1 if high else 0)

    def read_dout(self) -> bool:
        return bool(self._lg.gpio_read(self._handle, self._data))

    def now_us(self) -> int:
        # Pulse widths are measured within one synchronous read, where the event loop's clock
        # stands still; a monotonic hardware clock is the only one that moves.
        return time.monotonic_ns() // 1000

    def close(self) -> None:
        if self._handle is None:
            return
        handle, self._handle = self._handle, None
        for gpio in (self._clock, self._data):
            with contextlib.suppress(Exception):  # closing anyway
                self._lg.gpio_free(handle, gpio)
        self._lg.gpiochip_close(handle)


def lgpio_lines_opener(chip: int, data_gpio: int, clock_gpio: int) -> Callable[[], LgpioHx711Lines]:
    """What ``drivers.hx711.Hx711`` takes as ``open_lines`` on a Pi."""
    return lambda: LgpioHx711Lines(chip, data_gpio, clock_gpio)
