"""The real serial port opener (pyserial-asyncio-fast)."""

from __future__ import annotations

from pathlib import Path

import pytest

from drivers.serial_port import open_serial


class TestOpenSerial:
    async def test_a_missing_port_raises_os_error_naming_it(self, tmp_path: Path) -> None:
        """No device: OSError whose message names the port (what the link logs)."""
        port = str(tmp_path / "ttyACM7")
        with pytest.raises(OSError, match="ttyACM7"):
            await open_serial(port, 115200)
