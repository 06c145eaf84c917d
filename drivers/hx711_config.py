"""The HX711 load cell's settings: the ``hx711`` config section, declared by ``Hx711Config``."""

from __future__ import annotations

from dataclasses import dataclass

from hal.options import load, section_of, setting
from hal.settings import SettingsView


@dataclass(frozen=True, slots=True)
class Hx711Config:
    """Its GPIO lines, channel, rate, calibration and filters."""

    source: str = setting("gpio", "Where DOUT and PD_SCK are: gpio (lgpio lines) or stream "
                          "(conversions written to the named pipe hx711.stream, "
                          "drivers/hx711_stream.py).", choices=("gpio", "stream"))
    stream: str = setting("", "Named pipe of conversions for hx711.source = stream.")
    gpiochip: int = setting(0, "GPIO chip number (/dev/gpiochipN).", min=0, max=64)
    data_gpio: int = setting(5, "GPIO line wired to DOUT.", min=0, max=511)
    clock_gpio: int = setting(6, "GPIO line wired to PD_SCK.", min=0, max=511)
    gain: str = setting("A128", "Channel and gain.", choices=("A128", "A64", "B32"))
    """A ``drivers.hx711.Gain`` member's name."""
    sps: int = setting(10, "Output rate the RATE pin selects.", choices=(10, 80))
    tare_offset: int = setting(0, "Raw reading of the empty bin (robotd probe hx711).",
                               min=-8388608, max=8388607, tunable=True)
    calibration_factor: float = setting(
        107374.0, "Raw counts per kg (robotd probe hx711 --known-kg); default: 20 kg 1 mV/V "
        "cell.", min=1e-6, max=1e9, tunable=True)
    average_window: int = setting(8, "Readings in the moving average.", min=1, max=256,
                                  tunable=True)
    median_window: int = setting(5, "Readings the outlier check compares against.",
                                 min=1, max=64)
    outlier_kg: float = setting(1.0, "Drop a reading this far from the recent median.",
                                min=0.001, max=1000, tunable=True)
    timeout_s: float = setting(1.0, "Longest wait for data-ready.", min=0.05, max=10)

    @classmethod
    def from_settings(cls, settings: SettingsView) -> Hx711Config:
        return load(cls, settings.section(HX711.name))


HX711 = section_of(Hx711Config, "hx711", "The HX711 load cell amplifier on two GPIO lines.")
