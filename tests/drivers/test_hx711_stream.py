"""The HX711 driver on a named pipe of conversions (``hx711.source = "stream"``)."""

from __future__ import annotations

import asyncio
import os
from pathlib import Path

import pytest

from drivers.hx711 import Gain, clock_out, from_settings
from drivers.hx711_stream import StreamHx711Lines, parse_code
from hal.devices import DeviceUnavailable
from robotd.config.loader import defaults
from robotd.config.settings import Settings

FACTOR = 100_000.0


def stream_settings(pipe: Path | str) -> Settings:
    values = defaults()
    values["hx711"].update(source="stream", stream=str(pipe), calibration_factor=FACTOR,
                           tare_offset=5000)
    return Settings(values)


class TestParseCode:
    @pytest.mark.parametrize(("line", "code"), [(b"0", 0), (b"-8388608", -0x800000),
                                                (b" 8388607\r", 0x7FFFFF), (b"123", 123)])
    def test_reads_a_signed_24_bit_code(self, line: bytes, code: int) -> None:
        """A decimal code in the chip's range, spaces around it allowed."""
        assert parse_code(line) == code

    @pytest.mark.parametrize("line", [b"8388608", b"-8388609", b"1.5", b"x", b""])
    def test_refuses_what_the_chip_cannot_give(self, line: bytes) -> None:
        assert parse_code(line) is None


class TestStreamLines:
    def test_clock_out_shifts_the_code_written_and_dout_waits_for_the_next(
            self, tmp_path: Path) -> None:
        """DOUT low once a code is in the pipe; the real clock_out reads it bit by bit (a
        negative one too), then DOUT stays high until the next code."""
        pipe = tmp_path / "hx.fifo"
        os.mkfifo(pipe)

        async def main() -> tuple[bool, int, bool, int]:
            lines = StreamHx711Lines(pipe, asyncio.get_running_loop())
            writer = os.open(pipe, os.O_WRONLY | os.O_NONBLOCK)
            try:
                ready = asyncio.Event()
                lines.on_dout_low(ready.set)
                os.write(writer, b"-123456\n")
                await asyncio.wait_for(ready.wait(), 5)
                low = not lines.read_dout()
                first = clock_out(lines, Gain.A64)  # 27 pulses
                high_after = lines.read_dout()
                os.write(writer, b"4242\n")
                ready.clear()
                lines.on_dout_low(ready.set)
                await asyncio.wait_for(ready.wait(), 5)
                return low, first, high_after, clock_out(lines, Gain.A128)
            finally:
                os.close(writer)
                lines.close()

        low, first, high_after, second = asyncio.run(main())
        assert low and first == -123456 and high_after and second == 4242

    def test_the_load_cell_weighs_the_codes_written(self, tmp_path: Path) -> None:
        """The driver from hx711.source = stream: codes of 2 kg over the tare weigh 2 kg."""
        pipe = tmp_path / "hx.fifo"
        os.mkfifo(pipe)

        async def main() -> float:
            cell = from_settings(stream_settings(pipe))
            # Read-write: the pipe takes codes before the driver opens it (Linux allows it).
            writer = os.open(pipe, os.O_RDWR | os.O_NONBLOCK)

            async def chip() -> None:
                while True:
                    os.write(writer, f"{5000 + round(2 * FACTOR)}\n".encode())
                    await asyncio.sleep(0.1)  # 10 SPS

            feeding = asyncio.create_task(chip())
            try:
                await cell.start()
                reading = await asyncio.wait_for(cell.next_reading(), 10)
                return reading.kg
            finally:
                feeding.cancel()
                await cell.close()
                os.close(writer)

        assert asyncio.run(main()) == pytest.approx(2.0)

    def test_a_path_that_is_no_pipe_is_refused_with_the_key(self, tmp_path: Path) -> None:
        plain = tmp_path / "codes.txt"
        plain.write_text("")

        async def main() -> None:
            StreamHx711Lines(plain, asyncio.get_running_loop())

        with pytest.raises(DeviceUnavailable, match=r"not a named pipe.*hx711\.stream"):
            asyncio.run(main())
