"""The daemon in-process: signals, motors stopped, estop on failing services, reload."""

from __future__ import annotations

import asyncio
import gc
import os
import signal
from collections.abc import Callable
from pathlib import Path
from typing import Any

from daemon_harness import RecordingMotors, RpcClient, running_daemon

from behaviours.context import RobotContext
from behaviours.profile import BaseProfile
from hal.backend import Devices
from hal.readings import MotorCommand


class FlakyService:
    """A critical behaviour service that crashes right after it comes up."""

    name = "flaky"
    critical = True
    depends_on: tuple[str, ...] = ()

    async def run(self, ready: Callable[[], None]) -> None:
        ready()
        await asyncio.sleep(0.01)
        msg = "encoder stuck"
        raise RuntimeError(msg)


class FlakyProfile(BaseProfile):
    name = "flaky"

    def services(self, ctx: RobotContext) -> list[Any]:
        return [FlakyService()]


class DrivingProfile(BaseProfile):
    """Drives forward for as long as the mission lasts."""

    name = "driving"

    def state_tasks(self) -> dict[str, Any]:
        async def drive(ctx: RobotContext) -> None:
            assert ctx.devices.motors is not None
            while True:
                await ctx.devices.motors.drive(MotorCommand(100, 100))
                await asyncio.sleep(0.01)

        return {"mission": drive}


class TestSignals:
    async def test_sigterm_stops_everything_with_the_motors_stopped_and_exit_0(self) -> None:
        motors = RecordingMotors()
        async with running_daemon(profile=DrivingProfile(), devices=Devices(motors=motors),
                                  handle_signals=True) as daemon:
            await daemon.machine.trigger("start_mission")
            await asyncio.sleep(0.05)
            stops_before = motors.stops
            os.kill(os.getpid(), signal.SIGTERM)
            code = await asyncio.wait_for(asyncio.shield(_run_task(daemon)), 5)
            commands_at_stop = len(motors.commands)
            await asyncio.sleep(0.05)
        assert code == 0
        assert motors.commands, "the mission drove the motors"
        assert motors.stops > stops_before
        assert len(motors.commands) == commands_at_stop, "nothing drives after the stop"

    async def test_sighup_with_a_broken_file_keeps_the_running_config(self,
                                                                      tmp_path: Path) -> None:
        config = tmp_path / "robotd.toml"
        config.write_text("[line_follow]\nkp = 0.9\n")
        async with running_daemon(config_path=config, handle_signals=True) as daemon:
            os.kill(os.getpid(), signal.SIGHUP)
            await asyncio.sleep(0.1)
            assert daemon.settings.get("line_follow.kp") == 0.9
            config.write_text("[line_follow]\nkp = = 2\nki = \"x\"\n")
            os.kill(os.getpid(), signal.SIGHUP)
            await asyncio.sleep(0.1)
            kept = daemon.settings.get("line_follow.kp")
            rejected = [e for e in daemon.events if e["kind"] == "config"][-1]
        assert kept == 0.9
        assert rejected["status"] == "rejected"
        assert rejected["problems"] == [
            f"{config}:2: line_follow.kp: TOML syntax error: Invalid value",
            f"{config}:3: line_follow.ki: expected a number, got a string ('x')"]


def _run_task(daemon: Any) -> asyncio.Task[int]:
    for task in asyncio.all_tasks():
        if task.get_coro().__qualname__ == "Daemon.run":  # type: ignore[union-attr]
            return task
    raise AssertionError("no daemon task")


class TestReload:
    async def test_reload_through_the_socket_reports_why_a_bad_file_was_refused(
            self, tmp_path: Path) -> None:
        config = tmp_path / "robotd.toml"
        config.write_text("[weight]\nmax_kg = 8.0\n")
        async with running_daemon(config_path=config) as daemon:
            client = await RpcClient.connect(str(daemon.socket_path))
            good = await client.call("reload")
            config.write_text("[weight]\nmax_kg = 8.0\ncolour = 1\n")
            bad = await client.call("reload")
            await client.close()
            assert daemon.settings.get("weight.max_kg") == 8.0
        assert good["result"]["changed"] == ["weight.max_kg"]
        assert bad["error"]["code"] == -32000
        (problem,) = bad["error"]["data"]["problems"]
        assert problem.startswith(f"{config}:3: weight.colour: unknown key")


class TestEstop:
    async def test_a_critical_service_that_keeps_failing_puts_the_robot_in_estop(self) -> None:
        motors = RecordingMotors()
        async with running_daemon(profile=FlakyProfile(), devices=Devices(motors=motors),
                                  config={"supervisor": {"restart_base_s": 0.01,
                                                         "restart_max_s": 0.02,
                                                         "max_failures": 3}}) as daemon:
            for _ in range(200):
                if daemon.state == "estop":
                    break
                await asyncio.sleep(0.01)
            state = daemon.state
            estops = [e for e in daemon.events if e["kind"] == "estop"]
        assert state == "estop"
        assert "service flaky keeps failing: RuntimeError: encoder stuck" in estops[0]["reason"]
        assert motors.stops >= 1

    async def test_estop_and_resume_through_the_socket(self) -> None:
        motors = RecordingMotors()
        async with running_daemon(devices=Devices(motors=motors)) as daemon:
            client = await RpcClient.connect(str(daemon.socket_path))
            stopped = await client.call("estop")
            again = await client.call("resume")
            refused = await client.call("resume")
            await client.close()
        assert {k: stopped["result"][k] for k in ("state", "estop")} == {
            "state": "estop", "estop": True}
        assert again["result"]["state"] == "idle"
        assert refused["error"]["message"] == "cannot resume: not in estop (state idle)"
        assert motors.stops >= 2


class TestStore:
    async def test_mission_state_put_by_a_behaviour_is_there_after_a_restart(
            self, tmp_path: Path) -> None:
        async with running_daemon(state_dir=tmp_path) as daemon:
            daemon.context.store.put("laundry.request", {"id": 42, "loaded": True})
        async with running_daemon(state_dir=tmp_path) as daemon:
            restored = daemon.context.store.get("laundry.request")
        assert restored == {"id": 42, "loaded": True}

    async def test_a_started_daemon_freezes_what_start_up_made(self) -> None:
        """``robotd run`` takes start-up's objects out of the collector's reach, so a full
        collection later does not pause the control loops for tens of milliseconds."""
        gc.unfreeze()
        try:
            async with running_daemon(freeze_gc=True) as daemon:
                frozen = gc.get_freeze_count()
                assert daemon.ready.is_set()
        finally:
            gc.unfreeze()  # this test process runs many daemons: give them back to the GC
        assert frozen > 10_000

