"""The fake MCU served on a real pseudo-terminal (real event loop: a kernel pty is involved)."""

from __future__ import annotations

import asyncio
from pathlib import Path

from serial_frames import frame_body

from drivers.serial_port import open_serial
from sim.devices.motor_board.fake_mcu import FakeMcu
from sim.devices.motor_board.pty_mcu import PtyMcu
from sim.world.plant import RecordingPlant


async def reply(reader: asyncio.StreamReader) -> bytes:
    while True:
        line = await asyncio.wait_for(reader.readline(), 2.0)
        if line.startswith(b"#"):
            return line.split(b"*")[0]


class TestPtyMcu:
    async def test_a_driver_port_opened_by_pyserial_talks_to_the_fake(self,
                                                                     tmp_path: Path) -> None:
        """The symlinked pty opens with pyserial; frames are answered; the servo moves."""
        plant = RecordingPlant()
        server = PtyMcu(FakeMcu(plant), link=tmp_path / "ttyFAKE")
        path = await server.start()
        try:
            reader, writer = await open_serial(path, 115200)
            writer.write(frame_body(b"#1 SERVO:77"))
            assert await reply(reader) == b"#1 ACK"
            assert plant.servo_angles == [77]
            writer.close()
        finally:
            await server.close()

    async def test_unplug_removes_the_port_and_replug_brings_it_back(self,
                                                                    tmp_path: Path) -> None:
        """unplug(): the open port fails and the path is gone; replug(): a new pty behind the
        same path answers again."""
        mcu = FakeMcu(RecordingPlant())
        link = tmp_path / "ttyFAKE"
        server = PtyMcu(mcu, link=link)
        await server.start()
        try:
            reader, writer = await open_serial(str(link), 115200)
            mcu.unplug()
            assert not link.is_symlink()
            try:
                data = await asyncio.wait_for(reader.read(4096), 2.0)
                while data:
                    data = await asyncio.wait_for(reader.read(4096), 2.0)
            except OSError:
                pass
            writer.close()
            mcu.replug()
            for _ in range(100):
                if link.is_symlink():
                    break
                await asyncio.sleep(0.01)
            reader, writer = await open_serial(str(link), 115200)
            writer.write(frame_body(b"#5 HB"))
            assert await reply(reader) == b"#5 ACK"
            writer.close()
        finally:
            await server.close()
