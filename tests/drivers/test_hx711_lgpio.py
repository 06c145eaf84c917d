"""The HX711's lines on lgpio: claims, release, and DOUT's falling edge from lgpio's thread."""

from __future__ import annotations

import asyncio
import importlib.util
import threading
from typing import Any

import pytest

from drivers.gpio_lgpio import LgpioHx711Lines
from hal.devices import DeviceUnavailable
from hal.ports import DoutAlert, Hx711Lines, SckPulse


class FakeLgpio:
    """Records what the driver asks of lgpio; ``fall()`` reports DOUT's edge like lgpio."""

    FALLING_EDGE = 2

    def __init__(self, fail_open: bool = False) -> None:
        self.fail_open = fail_open
        self.calls: list[tuple[Any, ...]] = []
        self.level = 1
        self.alert_funcs: dict[int, Any] = {}

    def gpiochip_open(self, chip: int) -> int:
        if self.fail_open:
            raise OSError("can not open gpiochip")
        self.calls.append(("open", chip))
        return 7

    def gpio_claim_output(self, h: int, gpio: int, level: int) -> None:
        self.calls.append(("out", gpio, level))

    def gpio_claim_alert(self, h: int, gpio: int, eflags: int) -> None:
        self.calls.append(("alert", gpio, eflags))

    def callback(self, h: int, gpio: int, edge: int, func: Any) -> Any:
        self.alert_funcs[gpio] = func
        calls = self.calls
        return type("Cb", (), {"cancel": lambda _self: calls.append(("cancel", gpio))})()

    def gpio_write(self, h: int, gpio: int, level: int) -> None:
        self.calls.append(("write", gpio, level))

    def gpio_read(self, h: int, gpio: int) -> int:
        return self.level

    def gpio_free(self, h: int, gpio: int) -> None:
        self.calls.append(("free", gpio))

    def gpiochip_close(self, h: int) -> None:
        self.calls.append(("close", h))

    def fall(self, gpio: int) -> None:
        """DOUT falls: lgpio calls the alert function from its own thread."""
        self.level = 0
        thread = threading.Thread(target=self.alert_funcs[gpio], args=(0, gpio, 0, 123))
        thread.start()
        thread.join()


class TestLgpioLines:
    def test_claims_clock_low_and_data_as_alert_then_frees_them(self) -> None:
        """PD_SCK is claimed as an output driven low (powered up), DOUT as a falling-edge
        alert input; close cancels the alert and frees both."""
        lg = FakeLgpio()
        lines = LgpioHx711Lines(0, data_gpio=5, clock_gpio=6, lgpio_module=lg)
        lines.set_sck(True)
        assert lines.read_dout() is True
        lines.close()
        lines.close()
        assert lg.calls == [("open", 0), ("out", 6, 0), ("alert", 5, 2), ("write", 6, 1),
                            ("cancel", 5), ("free", 6), ("free", 5), ("close", 7)]

    def test_offers_the_three_ports(self) -> None:
        """The lgpio lines are ``Hx711Lines``, ``DoutAlert`` and ``SckPulse``."""
        lines = LgpioHx711Lines(0, 5, 6, lgpio_module=FakeLgpio())
        assert isinstance(lines, Hx711Lines) and isinstance(lines, DoutAlert)
        assert isinstance(lines, SckPulse)

    def test_a_pulse_writes_the_clock_high_then_low(self) -> None:
        """``pulse_sck`` drives PD_SCK high then low and returns a high time in us;
        ``pulse_sck_read`` also reads DOUT."""
        lg = FakeLgpio()
        lines = LgpioHx711Lines(0, data_gpio=5, clock_gpio=6, lgpio_module=lg)
        high_us = lines.pulse_sck()
        assert lg.calls[-2:] == [("write", 6, 1), ("write", 6, 0)]
        assert 0 <= high_us < 1_000_000
        lg.level = 0
        high_us, dout = lines.pulse_sck_read()
        assert lg.calls[-2:] == [("write", 6, 1), ("write", 6, 0)]
        assert 0 <= high_us < 1_000_000 and dout is False

    def test_missing_chip_is_device_unavailable(self) -> None:
        """A chip that cannot be opened names /dev/gpiochipN."""
        with pytest.raises(DeviceUnavailable, match="/dev/gpiochip4"):
            LgpioHx711Lines(4, 5, 6, lgpio_module=FakeLgpio(fail_open=True))

    @pytest.mark.skipif(importlib.util.find_spec("lgpio") is not None,
                        reason="lgpio is installed here")
    def test_missing_lgpio_says_how_to_install_it(self) -> None:
        """Without lgpio the error names the pi extra."""
        with pytest.raises(DeviceUnavailable, match=r"robotd\[pi\]"):
            LgpioHx711Lines(0, 5, 6)


class TestLgpioDoutAlert:
    async def test_a_fall_on_lgpios_thread_calls_back_on_the_loop(self) -> None:
        """The alert from lgpio's thread runs the callback once, on the loop's thread."""
        lg = FakeLgpio()
        lines = LgpioHx711Lines(0, 5, 6, lgpio_module=lg)
        fired: list[int] = []
        woke = asyncio.Event()

        def callback() -> None:
            fired.append(threading.get_ident())
            woke.set()

        lines.on_dout_low(callback)
        await asyncio.sleep(0)
        assert fired == []
        lg.fall(5)
        lg.fall(5)  # a second fall: the callback was for one
        await asyncio.wait_for(woke.wait(), 1.0)
        await asyncio.sleep(0)
        assert fired == [threading.get_ident()]

    async def test_dout_already_low_calls_back_without_an_edge(self) -> None:
        """A conversion that was ready before the wait began is reported at once."""
        lg = FakeLgpio()
        lg.level = 0
        lines = LgpioHx711Lines(0, 5, 6, lgpio_module=lg)
        woke = asyncio.Event()
        lines.on_dout_low(woke.set)
        await asyncio.wait_for(woke.wait(), 1.0)

    async def test_cancelled_wait_is_not_called(self) -> None:
        """After cancel, a fall calls nothing."""
        lg = FakeLgpio()
        lines = LgpioHx711Lines(0, 5, 6, lgpio_module=lg)
        fired: list[bool] = []
        cancel = lines.on_dout_low(lambda: fired.append(True))
        cancel()
        lg.fall(5)
        await asyncio.sleep(0.01)
        assert fired == []

    async def test_other_levels_are_not_falls(self) -> None:
        """lgpio's rising and watchdog reports (levels 1 and 2) wake nothing."""
        lg = FakeLgpio()
        lines = LgpioHx711Lines(0, 5, 6, lgpio_module=lg)
        fired: list[bool] = []
        lines.on_dout_low(lambda: fired.append(True))
        lg.alert_funcs[5](0, 5, 1, 0)
        lg.alert_funcs[5](0, 5, 2, 0)
        await asyncio.sleep(0.01)
        assert fired == []
