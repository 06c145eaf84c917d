"""``robotd probe lidar`` on a pseudo-terminal carrying a faulty recorded-style LD19 stream,
and on the simulated LD19 (real loop, subprocess)."""

from __future__ import annotations

import asyncio
import json
import os
import sys
import tty
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parents[2] / "drivers"))

from lidar_stream import faulty_stream

ROBOTD = Path(sys.executable).with_name("robotd")


async def start_probe(*args: str) -> asyncio.subprocess.Process:
    command = [str(ROBOTD), "probe", "lidar", *args] if ROBOTD.exists() else [
        sys.executable, "-m", "robotd.probes.lidar", *args]
    return await asyncio.create_subprocess_exec(*command, stdout=asyncio.subprocess.PIPE,
                                                stderr=asyncio.subprocess.PIPE)


async def finish(proc: asyncio.subprocess.Process) -> tuple[int, str, str]:
    out, err = await asyncio.wait_for(proc.communicate(), 60)
    return proc.returncode or 0, out.decode(), err.decode()


async def wait_until_open(pid: int, path: str, timeout_s: float = 20.0) -> None:
    """Until process ``pid`` holds ``path`` open (pyserial flushes input as it opens)."""
    loop = asyncio.get_running_loop()
    deadline_s = loop.time() + timeout_s
    fd_dir = f"/proc/{pid}/fd"
    while loop.time() < deadline_s:
        try:
            if any(os.readlink(f"{fd_dir}/{fd}") == path for fd in os.listdir(fd_dir)):
                await asyncio.sleep(0.3)  # past the open's termios setup and flush
                return
        except (FileNotFoundError, ProcessLookupError):
            pass
        await asyncio.sleep(0.02)
    msg = f"the probe did not open {path} within {timeout_s} s"
    raise TimeoutError(msg)


class TestProbeLidar:
    async def test_on_a_pty_every_intact_packet_is_counted_and_every_damaged_one(self) -> None:
        """A recorded-style stream (CRC damage, truncations, stray header bytes, 54 2C in
        distances, a timestamp wrap) on a pty: the probe's packets equal the intact ones,
        CRC errors cover the damaged ones, whole scans come out; the recording then ends, so
        the LiDAR is stale when the probe stops: exit 1, as for a sensor that fell silent."""
        stream = faulty_stream(600, seed=11, fault_rate=0.2)
        master, slave = os.openpty()
        tty.setraw(slave)
        path = os.ttyname(slave)
        loop = asyncio.get_running_loop()
        writer = os.fdopen(os.dup(master), "wb", buffering=0)
        transport, _ = await loop.connect_write_pipe(asyncio.Protocol, writer)
        try:
            proc = await start_probe("--port", path, "--seconds", "1.5", "--json")
            await wait_until_open(proc.pid, path)
            transport.write(stream.data)
            code, out, err = await finish(proc)
        finally:
            transport.close()
            os.close(master)
            os.close(slave)
        assert code == 1, err
        report = json.loads(out)
        assert report["stale"] and report["stale_events"] == 1
        assert report["bytes"] == len(stream.data)
        assert report["packets"] == len(stream.intact)
        assert report["crc_errors"] + report["implausible"] >= stream.damaged
        assert report["resyncs"] > 0 and report["skipped_bytes"] > 0
        assert report["scans"] >= 10 and report["points_per_scan"] > 300

    async def test_the_simulated_lidar_reads_the_room_and_a_missing_port_exits_1(
            self, tmp_path: Path) -> None:
        """--sim: about 10 Hz, 450 points, the wall 1 m ahead; no port: exit 1 naming it."""
        code, out, err = await finish(await start_probe("--sim", "--seconds", "2"))
        assert code == 0, err
        assert "10.0 Hz" in out or "9.9" in out
        assert "450 points/scan" in out and "ahead 1.0" in out
        code, _, err = await finish(await start_probe("--port", str(tmp_path / "nothing"),
                                                      "--seconds", "1"))
        assert code == 1 and "nothing" in err
        code, _, err = await finish(await start_probe("--sim", "--model", "ld99"))
        assert code == 2 and "ld99" in err
