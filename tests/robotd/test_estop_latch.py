"""The e-stop is a latch: persisted before it is acknowledged, kept across SIGKILL, until resume.

The process test runs ``robotd run`` with the real Arduino driver on a pty served by the fake
MCU (as ``test_run_with_motor_board``), kills it with SIGKILL and starts it again on the same
state directory and the same board.
"""

from __future__ import annotations

import asyncio
import os
import signal
import socket
import sys
import tempfile
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Any

import pytest
from daemon_harness import RecordingMotors, RpcClient, running_daemon

from hal.backend import Devices
from robotd import ctl
from sim.devices.motor_board.fake_mcu import FakeMcu
from sim.devices.motor_board.pty_mcu import PtyMcu
from sim.world.plant import RecordingPlant

START_GUARD_S = 30.0


class RobotdProcess:
    """``robotd run`` on the board's pty; ``ready()`` waits for READY=1."""

    def __init__(self, work: Path, config: Path, index: int) -> None:
        self.work = work
        self.config = config
        self.notify_path = work / f"notify-{index}"
        self.proc: asyncio.subprocess.Process | None = None
        self.notify = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        self.notify.bind(str(self.notify_path))
        self.notify.setblocking(False)

    async def start(self) -> None:
        env = dict(os.environ, NOTIFY_SOCKET=str(self.notify_path))
        env.pop("JOURNAL_STREAM", None)
        self.proc = await asyncio.create_subprocess_exec(
            sys.executable, "-m", "robotd.cli", "run", "--config", str(self.config), env=env,
            stdout=asyncio.subprocess.DEVNULL, stderr=asyncio.subprocess.DEVNULL)
        notices = b""
        loop = asyncio.get_running_loop()
        while b"READY=1" not in notices:
            notices += await asyncio.wait_for(loop.sock_recv(self.notify, 4096), START_GUARD_S)

    async def call(self, method: str, params: dict[str, Any] | None = None) -> dict[str, Any]:
        client = await RpcClient.connect(str(self.work / "control.sock"))
        try:
            reply = await client.call(method, params)
        finally:
            await client.close()
        return reply

    async def kill(self) -> None:
        assert self.proc is not None
        self.proc.send_signal(signal.SIGKILL)
        await self.proc.wait()

    async def close(self) -> None:
        if self.proc is not None and self.proc.returncode is None:
            self.proc.kill()
            await self.proc.wait()
        self.notify.close()


@asynccontextmanager
async def board_and_config() -> AsyncIterator[tuple[Path, Path, FakeMcu]]:
    with tempfile.TemporaryDirectory(prefix="rd-") as name:
        work = Path(name)
        mcu = FakeMcu(RecordingPlant())
        board = PtyMcu(mcu, link=work / "ttyACM0")
        port = await board.start()
        config = work / "robotd.toml"
        config.write_text(f'[robot]\nprofile = "idle"\nstate_dir = "{work / "state"}"\n'
                          f'[control]\nsocket = "{work / "control.sock"}"\n'
                          f'[hal]\ndevices = ["motors"]\n[serial]\nport = "{port}"\n')
        try:
            yield work, config, mcu
        finally:
            await board.close()


def moving(payloads: list[str]) -> list[str]:
    """MOTOR commands that turn a wheel."""
    return [p for p in payloads if p.startswith("MOTOR:") and p.split(":")[1].split(",")[:2]
            != ["0", "0"]]


class TestLatchAcrossSigkill:
    async def test_estop_sigkill_restart_comes_up_in_estop_until_resume(self) -> None:
        """robotctl estop, SIGKILL, restart: status shows the latched estop and its cause,
        the board got STOP and nothing moved, until resume; the resume itself survives a
        second SIGKILL."""
        async with board_and_config() as (work, config, mcu):
            first = RobotdProcess(work, config, 0)
            second = RobotdProcess(work, config, 1)
            third = RobotdProcess(work, config, 2)
            try:
                await first.start()
                acked = (await first.call("estop", {"reason": "hand on the button"}))["result"]
                await first.kill()
                before = len(mcu.executed)
                await second.start()
                await asyncio.sleep(0.5)
                status = (await second.call("status"))["result"]
                after_restart = [e.payload for e in list(mcu.executed)[before:]]
                resumed = (await second.call("resume"))["result"]
                await second.kill()
                await third.start()
                final = (await third.call("status"))["result"]
            finally:
                for robot in (first, second, third):
                    await robot.close()
        assert acked["latched"] is True
        assert status["state"] == "estop"
        assert status["estop"] is True
        assert status["estop_latch"]["source"] == "robotctl"
        assert status["estop_latch"]["reason"] == "hand on the button"
        assert status["estop_latch"]["at"].endswith("+00:00")
        assert "STOP" in after_restart
        assert moving(after_restart) == []
        assert resumed == {"state": "idle", "estop": False, "estop_latch": None}
        assert final["state"] == "idle"
        assert final["estop"] is False


class TestLatchInProcess:
    async def test_a_critical_fault_latches_and_the_next_daemon_starts_in_estop(
            self, tmp_path: Path) -> None:
        """An e-stop from a critical fault is latched; a daemon killed without its orderly
        stop (its store abandoned) and started again is in estop with the fault as cause."""
        motors = RecordingMotors()
        async with running_daemon(devices=Devices(motors=motors), state_dir=tmp_path) as d:
            await d.estop("service wheels keeps failing: boom", source="fault")
            d.store.abandon()  # nothing more reaches the disk, as after a SIGKILL
        again = RecordingMotors()
        async with running_daemon(devices=Devices(motors=again), state_dir=tmp_path) as d:
            state, latch = d.state, d.context.estop_latch.record
        assert state == "estop"
        assert latch is not None
        assert latch["source"] == "fault"
        assert latch["reason"] == "service wheels keeps failing: boom"
        assert again.stops >= 1
        assert again.commands == []

    async def test_a_second_cause_is_added_not_written_over(self, tmp_path: Path) -> None:
        """While latched, another e-stop keeps the first cause and lists the next in also."""
        async with running_daemon(state_dir=tmp_path) as d:
            await d.estop("first", source="robotctl")
            await d.estop("second", source="fault")
            latch = d.context.estop_latch.record
        assert latch is not None
        assert (latch["source"], latch["reason"], latch["also"]) == ("robotctl", "first",
                                                                     ["fault"])

    async def test_resume_clears_the_latch_durably(self, tmp_path: Path) -> None:
        """After resume the latch is gone from the disk, even if the daemon is then killed."""
        async with running_daemon(state_dir=tmp_path) as d:
            await d.estop("stop", source="robotctl")
            assert await d.machine.trigger("resume")
            d.store.abandon()
        async with running_daemon(state_dir=tmp_path) as d:
            state = d.state
        assert state == "idle"


class TestRobotctlShowsTheLatch:
    async def test_status_says_why_and_since_when(self, tmp_path: Path,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
        """``robotctl status`` shows the latched e-stop's source, reason and time."""
        async with running_daemon(state_dir=tmp_path) as d:
            await d.estop("hand on the button", source="robotctl")
            capsys.readouterr()
            code = await asyncio.to_thread(ctl.main, ["--socket", str(d.socket_path), "status"])
            out = capsys.readouterr().out
        assert code == 0
        line = next(x for x in out.splitlines() if x.startswith("estop"))
        assert "YES (latched: robotctl, 'hand on the button', at 20" in line
