"""``drive`` (``robotctl drive``): a technician's teleoperation through the control socket,
with a 0.5 s deadman, refused outside idle and maintenance, and the e-stop above it."""

from __future__ import annotations

import asyncio
from typing import Any

import pytest
from daemon_harness import RecordingMotors, RpcClient, running_daemon

from hal.backend import Devices
from robotd.control.teleop import HOLD_S
from robotd.ctl import build_parser
from sim import vclock


async def _session(steps: Any) -> tuple[RecordingMotors, list[dict[str, Any]], Any]:
    motors = RecordingMotors()
    async with running_daemon(devices=Devices(motors=motors)) as daemon:
        client = await RpcClient.connect(str(daemon.socket_path))
        try:
            out = await steps(client, daemon, motors)
        finally:
            await client.close()
        return motors, list(daemon.events), out


class TestDrive:
    def test_a_command_drives_and_the_deadman_stops_it(self) -> None:
        """One command turns the wheels; with no refresh they stop after the hold (0.5 s)
        and no command follows the stop."""
        async def steps(client: RpcClient, _d: Any, motors: RecordingMotors) -> Any:
            reply = await client.call("drive", {"linear_mps": 0.2, "angular_rad_s": 0.0})
            await asyncio.sleep(0.2)
            sent = len(motors.commands)
            stops = motors.stops
            await asyncio.sleep(HOLD_S + 0.5)
            after = len(motors.commands)
            await asyncio.sleep(0.5)
            return reply, sent, stops, after, len(motors.commands), motors.stops

        motors, events, (reply, sent, stops, after, later, stops_end) = vclock.run(
            _session(steps))
        assert reply["result"]["hold_s"] == HOLD_S
        assert sent >= 1 and motors.commands[0].left_forward and motors.commands[0].left_pwm > 0
        assert stops_end > stops  # the deadman stopped the motors
        assert later == after  # and nothing drove them since
        stopped = [e for e in events if e["kind"] == "teleop.stopped"]
        assert stopped and stopped[0]["reason"] == "deadman"

    def test_refreshed_it_keeps_driving(self) -> None:
        """A refresh every 0.2 s keeps the wheels turning past the hold."""
        async def steps(client: RpcClient, _d: Any, motors: RecordingMotors) -> Any:
            for _ in range(8):  # 1.6 s
                await client.call("drive", {"linear_mps": 0.1, "angular_rad_s": 0.5})
                await asyncio.sleep(0.2)
            return motors.stops

        motors, events, _stops = vclock.run(_session(steps))
        assert len(motors.commands) >= 14
        assert not [e for e in events if e["kind"] == "teleop.stopped"]
        # turning left: the right wheel faster
        assert motors.commands[-1].right_pwm > motors.commands[-1].left_pwm

    def test_the_estop_wins_and_then_driving_is_refused(self) -> None:
        """An e-stop during a drive stops it at once (no command after it); a drive in estop
        is refused with a line that says why."""
        async def steps(client: RpcClient, _d: Any, motors: RecordingMotors) -> Any:
            await client.call("drive", {"linear_mps": 0.2})
            await asyncio.sleep(0.15)
            await client.call("estop", {"reason": "test"})
            at_estop = len(motors.commands)
            await asyncio.sleep(0.5)
            refused = await client.call("drive", {"linear_mps": 0.2})
            return at_estop, len(motors.commands), refused

        _motors, events, (at_estop, after, refused) = vclock.run(_session(steps))
        assert after == at_estop
        assert refused["error"]["code"] not in (-32602, -32601)  # an application error
        assert "refused in state estop" in refused["error"]["message"]
        assert next(e for e in events if e["kind"] == "teleop.stopped")["reason"] == "estop"

    @pytest.mark.parametrize("params", [{"linear_mps": "fast"}, {"linear_mps": 9.0},
                                        {"angular_rad_s": [1]}, {"speed": 1}])
    def test_bad_params_are_invalid_params(self, params: dict[str, Any]) -> None:
        async def steps(client: RpcClient, _d: Any, _m: RecordingMotors) -> Any:
            return await client.call("drive", params)

        _motors, _events, reply = vclock.run(_session(steps))
        assert reply["error"]["code"] == -32602
        assert "drive:" in reply["error"]["message"]


class TestRobotctl:
    def test_drive_and_map_save_parse(self) -> None:
        """``robotctl drive --linear V --angular W --for S`` and ``map save NAME``."""
        args = build_parser().parse_args(["drive", "--linear", "0.2", "--for", "2"])
        assert (args.linear, args.angular, args.for_s, args.keys) == (0.2, 0.0, 2.0, False)
        from robotd.ctl import _request

        args = build_parser().parse_args(["map", "save", "depot"])
        assert _request(args) == ("save_map", {"name": "depot"})

    def test_the_keys_mode_steps_speed_and_turn(self) -> None:
        """w/s step the speed by 5 cm/s, a/d the turn by 0.2 rad/s, space stops, others
        change nothing; the limits hold."""
        from robotd.ctl.drive import _key

        assert _key("w", 0.0, 0.0) == (0.05, 0.0)
        assert _key("s", 0.05, 0.4) == (0.0, 0.4)
        assert _key("a", 0.1, 0.0) == (0.1, 0.2)
        assert _key("d", 0.1, 0.0) == (0.1, -0.2)
        assert _key(" ", 0.3, 1.0) == (0.0, 0.0)
        assert _key("x", 0.3, 1.0) == (0.3, 1.0)
        assert _key("w", 1.0, 0.0) == (1.0, 0.0)
