"""The dock IR receivers on a named pipe of edges (``docking.ir_source = "stream"``)."""

from __future__ import annotations

import asyncio
import os
import random
import time
from pathlib import Path
from typing import Any

import pytest

from drivers.dock_ir import from_settings
from drivers.dock_ir.config import DockIrConfig
from drivers.dock_ir.edge_stream import StreamIrEdges, parse_edge
from hal.devices import DeviceUnavailable
from hal.ports import IrEdge
from robotd.config.loader import defaults
from robotd.config.settings import Settings
from sim.devices import ir_emitter as em

NAMES = frozenset({"omni", "front_left"})


def stream_settings(pipe: Path | str) -> Settings:
    values = defaults()
    values["docking"].update(ir_source="stream", ir_stream=str(pipe))
    return Settings(values)


class TestParseEdge:
    def test_reads_time_receiver_and_level(self) -> None:
        """``T_US NAME LEVEL`` is one edge; the level is 0 or 1."""
        assert parse_edge(b"8123456789 omni 0", NAMES) == IrEdge("omni", False, 8123456789)
        assert parse_edge(b"12 front_left 1\r", NAMES) == IrEdge("front_left", True, 12)

    @pytest.mark.parametrize("line", [b"", b"12 omni", b"12 omni 2", b"x omni 1",
                                      b"-5 omni 1", b"12 rear 1", b"12 \xff 1",
                                      b"12 omni 1 extra"])
    def test_refuses_what_is_not_an_edge_of_a_fitted_receiver(self, line: bytes) -> None:
        """A short, malformed or foreign line is no edge (the source counts it)."""
        assert parse_edge(line, NAMES) is None


class TestStreamSource:
    def test_the_device_decodes_edges_written_to_the_pipe(self, tmp_path: Path) -> None:
        """Green-buoy frames written to the pipe on the monotonic clock are decoded for
        front_left; a garbage line in between is counted and loses nothing."""
        pipe = tmp_path / "ir.fifo"
        os.mkfifo(pipe)

        async def main() -> tuple[Any, dict[str, Any], int]:
            device = from_settings(stream_settings(pipe))
            await device.start()
            writer = os.open(pipe, os.O_WRONLY | os.O_NONBLOCK)
            t0_us = time.monotonic_ns() // 1000  # the pipe's clock (CLOCK_MONOTONIC)
            marks, _ = em.stream_marks([164] * 4, t0_us + 1000, jitter_us=100,
                                       rng=random.Random(1))
            lines = [f"{e.t_us} {e.receiver} {int(e.level)}\n"
                     for e in em.to_edges(marks, "front_left")]
            lines.insert(3, "this is no edge\n")
            os.write(writer, "".join(lines).encode())
            try:
                for _ in range(40):
                    reading = await device.next_reading()
                    if reading.codes.get("front_left"):
                        break
                return reading, device.status(), 0
            finally:
                os.close(writer)
                await device.close()

        reading, status, _ = asyncio.run(main())
        assert reading.codes["front_left"] == {164}
        assert reading.sees("front_left", "green_buoy")
        assert status["total"]["codes"] >= 3

    def test_a_writer_that_goes_and_comes_back_is_no_end(self, tmp_path: Path) -> None:
        """The first writer closes the pipe; the edges of the next one still arrive."""
        pipe = tmp_path / "ir.fifo"
        os.mkfifo(pipe)

        async def main() -> list[list[IrEdge]]:
            source = StreamIrEdges(pipe, ("omni",), asyncio.get_running_loop(), batch_s=0.0)
            batches = []
            try:
                for t_us in (100, 200):
                    writer = os.open(pipe, os.O_WRONLY | os.O_NONBLOCK)
                    os.write(writer, f"{t_us} omni 0\n{t_us + 50} omni 1\n".encode())
                    os.close(writer)
                    batches.append(await asyncio.wait_for(source.next_edges(), 5))
            finally:
                source.close()
            return batches

        first, second = asyncio.run(main())
        assert first == [IrEdge("omni", False, 100), IrEdge("omni", True, 150)]
        assert second == [IrEdge("omni", False, 200), IrEdge("omni", True, 250)]

    def test_a_path_that_is_no_pipe_is_refused_with_the_key(self, tmp_path: Path) -> None:
        """A regular file is not a pipe: DeviceUnavailable naming docking.ir_stream."""
        plain = tmp_path / "edges.txt"
        plain.write_text("")

        async def main() -> None:
            StreamIrEdges(plain, ("omni",), asyncio.get_running_loop())

        with pytest.raises(DeviceUnavailable, match=r"not a named pipe.*docking\.ir_stream"):
            asyncio.run(main())

    def test_stream_without_a_path_is_a_config_error(self) -> None:
        """ir_source = stream needs ir_stream: the error names the key."""
        with pytest.raises(ValueError, match=r"docking\.ir_stream: empty"):
            DockIrConfig.from_settings(stream_settings(""))
