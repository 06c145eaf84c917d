"""Encoder counts survive the trip from the wheels to the firmware's telemetry, exactly.

Counts used to be lost whenever a MOTOR command arrived: the firmware's ``analogWrite()``
rewrites DDRD, and simavr then pulled the encoder inputs (INPUT_PULLUP) back to high behind
the harness's back. These tests inject known transitions at wheel-like rates while the host
keeps sending MOTOR commands, and require the count to the tick.
"""

from __future__ import annotations

import asyncio

from firmware_client import PtyLink

from sim.devices.motor_board.simavr_bridge import SimavrBridge
from sim.devices.motor_board.simavr_mcu import SimavrMcu
from sim.world.body import BodyParams, DiffDriveBody
from sim.world.floor_plan import World
from sim.world.geometry import Pose

# (left, right) ticks per 10 ms message, and how many messages: about 600 transitions/s per
# wheel (0.6 m/s on a 35 mm wheel with 360 x4 ticks per turn is 980/s), both directions,
# turning in place, and a direction change at every message at the end.
PROFILE: list[tuple[int, int, int]] = [
    (6, 6, 60),
    (-4, 4, 40),
    (-5, -3, 30),
    (3, -2, 10), (-3, 2, 10), (3, -2, 10), (-3, 2, 10),
    (1, -1, 1), (-1, 1, 1), (2, -2, 1), (-2, 2, 1), (1, -1, 1), (-1, 1, 1),
]
MOTOR_COMMANDS = ["MOTOR:150,150,1,1", "MOTOR:0,0,1,1", "MOTOR:100,100,0,1", "MOTOR:80,0,1,0"]


async def encoder_total(link: PtyLink, want: str, timeout_s: float = 5.0) -> str:
    """The firmware's ENCODER body once it equals want, else the last one seen."""
    last = ""
    try:
        async with asyncio.timeout(timeout_s):
            while last != want:
                last = await link.telemetry_matching("ENCODER:")
    except TimeoutError:
        pass
    return last


class TestEncoderCounts:
    async def test_every_injected_transition_is_counted_while_motor_commands_arrive(
            self, mcu: SimavrMcu, link: PtyLink) -> None:
        """ENC every 10 ms and MOTOR every 50 ms, forward, backward, turning and reversing:
        the firmware reports exactly the injected totals and no input pin was moved."""
        loop = asyncio.get_running_loop()
        total = [0, 0]
        seq = 0
        next_t = loop.time()
        for left, right, count in PROFILE:
            for _ in range(count):
                if seq % 5 == 0:
                    link.send(f"{MOTOR_COMMANDS[seq // 5 % len(MOTOR_COMMANDS)]}\n".encode())
                seq += 1
                await mcu.inject_encoder(left, right)
                total[0] += left
                total[1] += right
                next_t += 0.01
                await asyncio.sleep(max(0.0, next_t - loop.time()))
        want = f"ENCODER:{total[0]},{total[1]}"
        assert await encoder_total(link, want) == want
        stats = await mcu.encoder_stats()
        assert (stats["played_l"], stats["played_r"]) == tuple(total)
        assert (stats["overridden_l"], stats["overridden_r"]) == (0, 0)

    async def test_a_body_driven_by_the_firmware_ends_with_the_same_count(
            self, mcu: SimavrMcu, link: PtyLink) -> None:
        """Through the plant bridge: drive, turn in place, stop; the firmware's ENCODER equals
        the body's wheel ticks to the tick."""
        loop = asyncio.get_running_loop()
        world = World.from_table({"width_m": 20, "height_m": 20})
        body = DiffDriveBody(world, Pose(2, 10, 0), BodyParams(slip_std=0), clock=loop.time)
        task = asyncio.create_task(SimavrBridge(mcu, body, period_s=0.01).run())
        try:
            for command, seconds in (("MOTOR:150,150,1,1", 1.0), ("MOTOR:100,100,0,1", 1.0),
                                     ("MOTOR:0,0,1,1", 0.5)):
                end = loop.time() + seconds
                while loop.time() < end:
                    link.send(f"{command}\n".encode())
                    await asyncio.sleep(0.05)
            left, right = body.encoder_ticks()
            assert right > 800  # it really moved
            want = f"ENCODER:{left},{right}"
            assert await encoder_total(link, want) == want
        finally:
            task.cancel()
