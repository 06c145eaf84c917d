"""``robotd probe serial`` against the fake MCU on a pseudo-terminal (real loop, subprocess)."""

from __future__ import annotations

import asyncio
import itertools
import json
import sys
from pathlib import Path

from sim.devices.motor_board.fake_mcu import FakeMcu
from sim.devices.motor_board.pty_mcu import PtyMcu
from sim.world.plant import RecordingPlant

ROBOTD = Path(sys.executable).with_name("robotd")


async def probe(*args: str) -> tuple[int, str, str]:
    command = [str(ROBOTD), "probe", "serial", *args] if ROBOTD.exists() else [
        sys.executable, "-m", "robotd.probes.serial", *args]
    proc = await asyncio.create_subprocess_exec(*command, stdout=asyncio.subprocess.PIPE,
                                                stderr=asyncio.subprocess.PIPE)
    out, err = await asyncio.wait_for(proc.communicate(), 120)
    return proc.returncode or 0, out.decode(), err.decode()


class TestProbeSerial:
    async def test_with_2pct_corruption_every_command_is_acked_and_run_exactly_once(
            self, tmp_path: Path) -> None:
        """200 commands at 100/s over a pty with 2 % of bytes corrupted both ways: the probe
        reports 200 acked and 0 lost with RTT figures, and the board executed every SEQ
        exactly once, in order."""
        mcu = FakeMcu(RecordingPlant(), seed=3)
        server = PtyMcu(mcu, link=tmp_path / "ttyACM0")
        port = await server.start()
        mcu.corrupt(2.0)
        try:
            code, out, err = await probe("--port", port, "--send", "MOTOR:90,90,1,1",
                                         "--count", "200", "--rate", "100", "--json")
        finally:
            await server.close()
        assert code == 0, err
        report = json.loads(out)
        assert (report["acked"], report["lost"], report["count"]) == (200, 0, 200)
        assert report["resent"] > 0 and report["rtt_p50_ms"] is not None
        assert report["rtt_p99_ms"] >= report["rtt_p50_ms"]
        motors = [e for e in mcu.executed if e.payload == "MOTOR:90,90,1,1"]
        assert len(motors) == 200
        seqs = [e.seq for e in mcu.executed if e.seq is not None]
        assert all(b == (a + 1) % 256 for a, b in itertools.pairwise(seqs)), seqs
        assert mcu.duplicates > 0  # resends happened and were not executed again

    async def test_human_output_and_exit_1_when_the_board_is_absent(self,
                                                                    tmp_path: Path) -> None:
        """A missing port: exit 1 and a message naming it; a present one: readable figures."""
        code, _, err = await probe("--port", str(tmp_path / "nothing"), "--count", "1")
        assert code == 1 and "nothing" in err
        server = PtyMcu(FakeMcu(RecordingPlant()), link=tmp_path / "ttyACM0")
        port = await server.start()
        try:
            code, out, err = await probe("--port", port, "--count", "5", "--rate", "0")
        finally:
            await server.close()
        assert code == 0, err
        assert "acked 5, resent 0, lost 0" in out and "RTT p50" in out
