"""The test bench for the Arduino link's tests: the real driver against the fake MCU over the
simulated serial ports, on the virtual clock."""

from __future__ import annotations

import asyncio
from collections.abc import Awaitable, Callable
from dataclasses import replace

from drivers.arduino import ArduinoLink, LinkConfig
from hal.ports import StreamPair
from sim import vclock
from sim.devices.motor_board.fake_mcu import FakeMcu
from sim.devices.sim_serial import SimSerialPorts
from sim.world.plant import RecordingPlant

PORT = "/dev/ttyACM0"


class Bench:
    """A fake board on a sim port, the bytes the host wrote, and a link to it."""

    def __init__(self, **config: object) -> None:
        self.plant = RecordingPlant()
        self.mcu = FakeMcu(self.plant, seed=11)
        self.ports = SimSerialPorts()
        self.ports.attach(PORT, self.mcu)
        self.wire: list[bytes] = []
        self.attempts: list[float] = []
        self.link = ArduinoLink(self.tap, replace(LinkConfig(port=PORT), **config))  # type: ignore[arg-type]

    async def tap(self, port: str, baud: int) -> StreamPair:
        self.attempts.append(asyncio.get_running_loop().time())
        reader, writer = await self.ports(port, baud)
        original = writer.write

        def write(data: bytes | bytearray | memoryview) -> None:
            self.wire.append(bytes(data))
            original(data)

        writer.write = write  # type: ignore[method-assign]
        return reader, writer

    def mcu_writes(self, data: bytes) -> None:
        """Bytes from the board's side of the line, as if the firmware sent them."""
        assert self.ports.pipe is not None
        self.ports.pipe.b[1].write(data)

    def seqs_on_wire(self) -> list[int]:
        return [int(frame[1:frame.index(b" ")]) for frame in self.wire if frame.startswith(b"#")]


def on_bench(scenario: Callable[[Bench], Awaitable[None]], **config: object) -> None:
    async def main() -> None:
        bench = Bench(**config)
        await bench.link.start()
        try:
            await scenario(bench)
        finally:
            await bench.link.close()
            await bench.mcu.close()

    vclock.run(main())
