"""``robotd run`` with the real Arduino driver on a pty served by the fake MCU: SIGTERM.

The daemon process opens the pty like ``/dev/ttyACM0``; this test plays the motor board.
"""

from __future__ import annotations

import asyncio
import os
import signal
import socket
import sys
import tempfile
from pathlib import Path

from sim.devices.motor_board.fake_mcu import FakeMcu
from sim.devices.motor_board.pty_mcu import PtyMcu
from sim.world.plant import RecordingPlant

STOP_LIMIT_S = 5.0
START_GUARD_S = 30.0


class TestSigtermWithMotors:
    async def test_sigterm_exits_0_within_5_s_and_the_board_got_stop(self) -> None:
        with tempfile.TemporaryDirectory(prefix="rd-") as name:
            work = Path(name)
            mcu = FakeMcu(RecordingPlant())
            board = PtyMcu(mcu, link=work / "ttyACM0")
            port = await board.start()
            config = work / "robotd.toml"
            config.write_text(f'[robot]\nprofile = "idle"\nstate_dir = "{work / "state"}"\n'
                              f'[control]\nsocket = "{work / "control.sock"}"\n'
                              f'[hal]\ndevices = ["motors"]\n[serial]\nport = "{port}"\n')
            notify = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
            notify.bind(str(work / "notify"))
            notify.setblocking(False)
            env = dict(os.environ, NOTIFY_SOCKET=str(work / "notify"))
            env.pop("JOURNAL_STREAM", None)
            proc = await asyncio.create_subprocess_exec(
                sys.executable, "-m", "robotd.cli", "run", "--config", str(config), env=env,
                stdout=asyncio.subprocess.DEVNULL, stderr=asyncio.subprocess.PIPE)
            try:
                loop = asyncio.get_running_loop()
                notices = b""
                while b"READY=1" not in notices:
                    notices += await asyncio.wait_for(loop.sock_recv(notify, 4096),
                                                      START_GUARD_S)
                before = len(mcu.executed)
                proc.send_signal(signal.SIGTERM)
                code = await asyncio.wait_for(proc.wait(), STOP_LIMIT_S)
                stderr = (await proc.stderr.read()).decode() if proc.stderr else ""
            finally:
                if proc.returncode is None:
                    proc.kill()
                    await proc.wait()
                notify.close()
                await board.close()
        after_sigterm = [e.payload for e in list(mcu.executed)[before:]]
        assert code == 0
        assert "STOP" in after_sigterm
        assert "motors.stopped" in stderr
        assert "Traceback" not in stderr
