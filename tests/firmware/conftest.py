"""Fixtures for the firmware tests: a freshly booted emulated motor board per test."""

from __future__ import annotations

from collections.abc import AsyncIterator

import pytest
from firmware_client import PtyLink

from sim.devices.motor_board.simavr_mcu import SimavrMcu, missing_toolchain


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    reason = missing_toolchain()
    for item in items:
        if "tests/firmware" in str(item.path):
            item.add_marker(pytest.mark.simavr)
            if reason is not None:
                item.add_marker(pytest.mark.skip(reason=reason))


@pytest.fixture
async def mcu() -> AsyncIterator[SimavrMcu]:
    async with await SimavrMcu.start() as board:
        await board.wait_for(lambda p: p.servo_period_us == 20000)  # setup() has run
        yield board


@pytest.fixture
async def link(mcu: SimavrMcu) -> AsyncIterator[PtyLink]:
    pty = PtyLink.open(mcu.uart_path)
    yield pty
    pty.close()
