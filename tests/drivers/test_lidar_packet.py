"""LDROBOT's CRC-8 table and the 47-byte packet's encode/decode."""

from __future__ import annotations

import numpy as np
import pytest

from drivers.lidar.crc import TABLE, crc8, crc8_rows
from drivers.lidar.packet import PACKET_BYTES, PACKET_DTYPE, Packet, from_records

PACKET = Packet(speed_dps=3600, start_cdeg=35500, end_cdeg=380, timestamp_ms=29999,
                distances_mm=tuple(range(1000, 1012)), intensities=tuple(range(200, 212)))


class TestCrc:
    def test_the_table_matches_ldrobots_sdk(self) -> None:
        """Entries copied from CrcTable in LDROBOT's lipkg.cpp (first row, a middle row, end)."""
        assert TABLE[:12] == (0x00, 0x4D, 0x9A, 0xD7, 0x79, 0x34, 0xE3, 0xAE, 0xF2, 0xBF,
                              0x68, 0x25)
        assert TABLE[120:132] == (0x7A, 0x37, 0xE0, 0xAD, 0x03, 0x4E, 0x99, 0xD4, 0x7C, 0x31,
                                  0xE6, 0xAB)
        assert TABLE[-4:] == (0x7F, 0x32, 0xE5, 0xA8)

    def test_rows_at_once_equal_one_at_a_time(self) -> None:
        """The numpy CRC of many rows equals the byte loop's for each row."""
        rows = np.random.default_rng(1).integers(0, 256, (50, 46), dtype=np.uint8)
        assert crc8_rows(rows).tolist() == [crc8(row.tobytes()) for row in rows]


class TestPacket:
    def test_encode_is_47_bytes_with_header_and_crc(self) -> None:
        """An encoded packet starts 54 2C, is 47 bytes, and ends with the CRC of the rest."""
        wire = PACKET.encode()
        assert len(wire) == PACKET_BYTES and wire[:2] == b"\x54\x2c"
        assert wire[46] == crc8(wire[:46])
        assert wire[2:4] == (3600).to_bytes(2, "little")

    def test_decode_reverses_encode_and_numpy_records_agree(self) -> None:
        """decode(encode(p)) == p, and the numpy record view gives the same fields."""
        wire = PACKET.encode()
        assert Packet.decode(wire) == PACKET
        assert from_records(np.frombuffer(wire, dtype=PACKET_DTYPE)) == [PACKET]

    @pytest.mark.parametrize(("wire", "message"), [
        (b"\x54\x2c" + bytes(40), "42 bytes"),
        (b"\x55" + PACKET.encode()[1:], "header 552c"),
        (PACKET.encode()[:46] + b"\x00", "CRC 00"),
    ])
    def test_decode_names_what_is_wrong(self, wire: bytes, message: str) -> None:
        """A short packet, a bad header or a bad CRC: ValueError saying which."""
        with pytest.raises(ValueError, match=message):
            Packet.decode(wire)
