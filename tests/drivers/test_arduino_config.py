"""The link's settings from the ``serial`` config section."""

from __future__ import annotations

from drivers.arduino import Framing, LinkConfig
from robotd.config.loader import defaults
from robotd.config.settings import Settings


class TestLinkConfig:
    def test_defaults_of_the_serial_section_are_the_contract(self) -> None:
        """Default config: 115200, crc, 500 ms ACK timeout, 3 resends, queue of 10."""
        config = LinkConfig.from_settings(Settings(defaults()))
        assert (config.baud, config.framing, config.ack_timeout_s, config.max_resends,
                config.queue_limit) == (115200, Framing.CRC, 0.5, 3, 10)
        assert config == LinkConfig()

    def test_a_command_is_given_up_after_all_resend_windows(self) -> None:
        """give_up_s = (max_resends + 1) * ack_timeout_s; silence_s at least that."""
        config = LinkConfig(ack_timeout_s=0.25, max_resends=2)
        assert config.give_up_s == 0.75 and config.silence_s >= 0.75

    def test_plain_framing_and_port_come_from_the_file(self) -> None:
        """serial.port and serial.framing = plain are taken over."""
        values = defaults()
        values["serial"].update(port="/dev/ttyUSB1", framing="plain")
        config = LinkConfig.from_settings(Settings(values))
        assert (config.port, config.framing) == ("/dev/ttyUSB1", Framing.PLAIN)
