"""The fake motor board's docking lines and EVAC, over the in-memory byte pipe."""

from __future__ import annotations

import asyncio
import contextlib
from collections import Counter

from drivers.arduino.crc8 import crc8
from sim import vclock
from sim.devices.motor_board.dock_inputs import PERIODS_S, DockInputs
from sim.devices.motor_board.fake_mcu import FakeMcu
from sim.devices.sim_serial import SimSerialPorts
from sim.world.plant import RecordingPlant

PORT = "/dev/ttyACM0"


def count_lines(mcu: FakeMcu, seconds: float, before: float = 0.0) -> tuple[Counter[str], int]:
    """Telemetry lines by name over ``seconds`` (after ``before`` s of setup), and how many
    framed lines had a bad CRC."""
    counts: Counter[str] = Counter()
    bad = 0

    async def main() -> None:
        nonlocal bad
        ports = SimSerialPorts()
        ports.attach(PORT, mcu)
        reader, _writer = await ports(PORT, 115200)
        await asyncio.sleep(before)
        loop = asyncio.get_running_loop()
        end_s = loop.time() + seconds
        try:
            while (remaining := end_s - loop.time()) > 0:
                try:
                    line = (await asyncio.wait_for(reader.readline(), remaining))[:-1]
                except TimeoutError:
                    break
                body, _, check = line.rpartition(b"*")
                if int(check, 16) != crc8(body):
                    bad += 1
                counts[body.split(b":")[0].decode()] += 1
        finally:
            await mcu.close()

    vclock.run(main())
    return counts, bad


class TestDockLines:
    def test_each_line_comes_at_its_rate_under_a_good_crc(self) -> None:
        """In 10 s: IRS 200, WALL 100, DOCK 50, BIN 10, BUMP 10 (and one more per change)."""
        mcu = FakeMcu(RecordingPlant())
        mcu.dock_signal, mcu.contact_mv, mcu.bumpers = (5, 6), 15_000, (False, False)
        mcu.wall_cm, mcu.bin_pct = 10.0, 3.0
        counts, bad = count_lines(mcu, 10.0, before=0.01)
        expected = {name: round(10.0 / period_s) for name, period_s in PERIODS_S.items()}
        for name, want in expected.items():
            assert abs(counts[name] - want) <= 1, (name, counts[name])
        assert counts["ENCODER"] == 200 and bad == 0

    def test_a_world_without_a_dock_gets_no_docking_line(self) -> None:
        """No source set: the board sends what it always sent, nothing more."""
        counts, _bad = count_lines(FakeMcu(RecordingPlant()), 5.0)
        assert set(counts) == {"ENCODER", "IR", "BAT"}

    def test_a_source_set_to_none_stops_its_line(self) -> None:
        """The world can take a sensor away again (None) and its line stops."""
        mcu = FakeMcu(RecordingPlant())
        mcu.wall_cm = 20.0

        async def main() -> None:
            ports = SimSerialPorts()
            ports.attach(PORT, mcu)
            reader, _writer = await ports(PORT, 115200)
            await asyncio.sleep(0.5)
            mcu.wall_cm = None
            loop = asyncio.get_running_loop()
            cut_s, after = loop.time() + 0.01, []  # a line already on the wire still arrives
            while (remaining := cut_s + 1.0 - loop.time()) > 0:
                with contextlib.suppress(TimeoutError):
                    line = await asyncio.wait_for(reader.readline(), remaining)
                    if loop.time() > cut_s:
                        after.append(line.split(b":")[0])
            assert b"ENCODER" in after and b"WALL" not in after
            await mcu.close()

        vclock.run(main())

    def test_lines_follow_the_plain_framing_after_a_plain_command(self) -> None:
        """After a bare command the docking lines come without ``*CC``, as the others."""
        mcu = FakeMcu(RecordingPlant())
        mcu.contact_mv = 17_000

        async def main() -> None:
            ports = SimSerialPorts()
            ports.attach(PORT, mcu)
            reader, writer = await ports(PORT, 115200)
            writer.write(b"HB\n")
            await asyncio.sleep(0.5)
            data = b""
            while b"DOCK:" not in data:
                data = await reader.readline()
            assert data == b"DOCK:17000\n"
            await mcu.close()

        vclock.run(main())


class TestEvac:
    def test_a_standalone_set_of_sources_records_evac_like_the_board(self) -> None:
        """DockInputs alone (a bench's) records EVAC changes once each and calls listeners."""
        dock = DockInputs()
        heard: list[bool] = []
        dock.evac_listeners.append(heard.append)
        for t_s, on in ((1.0, True), (1.5, True), (2.0, False)):
            dock.record_evac(on, t_s)
        assert dock.evac_log == [(1.0, True), (2.0, False)] and heard == [True, False]
