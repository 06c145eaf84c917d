"""CRC-8 of the serial link."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from drivers.arduino.crc8 import crc8, crc8_joined
from sim.devices.motor_board.mcu_frames import crc8_bitwise


class TestCrc8:
    def test_check_value_of_123456789_is_f4(self) -> None:
        """The contract's check value: CRC-8 (poly 0x07, init 0) of b"123456789" is 0xF4."""
        assert crc8(b"123456789") == 0xF4

    def test_empty_input_gives_the_initial_value(self) -> None:
        """No bytes, no change: 0x00."""
        assert crc8(b"") == 0x00

    @given(st.binary(max_size=80))
    def test_table_driver_matches_the_bitwise_firmware_algorithm(self, data: bytes) -> None:
        """The driver's table CRC equals the bit-by-bit CRC the firmware and FakeMcu use."""
        assert crc8(data) == crc8_bitwise(data)

    @given(st.binary(max_size=40), st.binary(max_size=40))
    def test_running_value_continues_over_chunks(self, head: bytes, tail: bytes) -> None:
        """Computing in two chunks gives the same CRC as in one."""
        assert crc8(tail, crc8(head)) == crc8(head + tail)

    @given(st.binary(min_size=1, max_size=60), st.data())
    def test_every_single_bit_flip_is_detected(self, data: bytes, draw: st.DataObject) -> None:
        """A one-bit error anywhere in a line changes the CRC."""
        bit = draw.draw(st.integers(0, len(data) * 8 - 1))
        flipped = bytearray(data)
        flipped[bit // 8] ^= 1 << (bit % 8)
        assert crc8(bytes(flipped)) != crc8(data)

    @given(st.binary(max_size=40), st.binary(max_size=64))
    def test_the_crc_of_two_parts_joins_into_the_crc_of_both(self, head: bytes,
                                                             tail: bytes) -> None:
        """crc8_joined(crc(head), crc(tail), len(tail)) is crc(head + tail)."""
        assert crc8_joined(crc8(head), crc8(tail), len(tail)) == crc8(head + tail)
