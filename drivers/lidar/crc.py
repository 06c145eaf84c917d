"""LDROBOT's CRC-8 of LD06/LD19/STL-19P packets: polynomial 0x4D, init 0, not reflected.

Checked against LDROBOT's own SDK: ``CrcTable`` and ``CalCRC8`` in
``ldlidar_driver/src/dataprocess/lipkg.cpp`` of github.com/ldrobotSensorTeam/ldlidar_stl_ros2
(table starts ``0x00, 0x4d, 0x9a, 0xd7``, ends ``0x32, 0xe5, 0xa8``; the CRC runs
``crc = CrcTable[crc ^ byte]`` from 0 over bytes 0-45). The table here is computed from the
polynomial and a test pins those entries, so a typo cannot hide in 256 literals.
"""

from __future__ import annotations

import functools

import numpy as np
import numpy.typing as npt

POLYNOMIAL = 0x4D


def _table() -> tuple[int, ...]:
    entries = []
    for byte in range(256):
        crc = byte
        for _ in range(8):
            crc = ((crc << 1) ^ POLYNOMIAL) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
        entries.append(crc)
    return tuple(entries)


TABLE: tuple[int, ...] = _table()
TABLE_NP: npt.NDArray[np.uint8] = np.array(TABLE, dtype=np.uint8)


def crc8(data: bytes | bytearray | memoryview) -> int:
    """CRC-8 of ``data`` as the LiDAR computes it."""
    table = TABLE
    crc = 0
    for byte in data:
        crc = table[crc ^ byte]
    return crc


def crc8_rows(rows: npt.NDArray[np.uint8]) -> npt.NDArray[np.uint8]:
    """CRC-8 of every row of a 2-D uint8 array at once.

    This CRC (init 0, no final xor) is linear over GF(2): the CRC of a row is the xor of the
    CRCs of each byte alone in its place, zeros elsewhere. Those come from a table per row
    length (column x byte value), so any number of rows costs two numpy operations.
    """
    table = _positional_table(rows.shape[1])
    picked = table[np.arange(rows.shape[1]), rows]
    crc: npt.NDArray[np.uint8] = np.bitwise_xor.reduce(picked, axis=1)
    return crc


@functools.cache
def _positional_table(length: int) -> npt.NDArray[np.uint8]:
    """[i, b]: the CRC of ``length`` bytes that are all zero but byte ``b`` at position i."""
    table = np.zeros((length, 256), dtype=np.uint8)
    crc = TABLE_NP.copy()  # byte b last: one table step
    for position in range(length - 1, -1, -1):
        table[position] = crc
        crc = TABLE_NP[crc]  # one more zero byte after it
    return table
