"""The link's outgoing queue: priorities, MOTOR replacement, bounded cosmetic commands."""

from __future__ import annotations

import asyncio

from drivers.arduino.outbox import Command, Delivery, Outbox, Outcome
from sim import vclock


def command(payload: str) -> Command:
    return Command(payload, asyncio.get_running_loop().create_future())


def outcome(cmd: Command) -> Outcome | None:
    assert cmd.future is not None
    return cmd.future.result().outcome if cmd.future.done() else None


def delivery(cmd: Command) -> Delivery:
    assert cmd.future is not None
    return cmd.future.result()


class TestOutbox:
    def test_stop_goes_first_then_motor_then_the_rest_in_order(self) -> None:
        """STOP beats MOTOR beats LED/servo commands, which keep their order."""

        async def main() -> list[str]:
            box = Outbox(limit=10)
            for payload in ("LED_IDLE", "SERVO:10", "MOTOR:1,1,1,1", "STOP", "LED_MOVING"):
                box.put(command(payload))
            return [c.payload for c in iter(box.pop, None)]

        assert vclock.run(main()) == ["STOP", "LED_IDLE", "SERVO:10", "LED_MOVING"]

    def test_a_newer_motor_replaces_a_queued_older_one(self) -> None:
        """Only the newest MOTOR waits; the older ends SUPERSEDED and is counted."""

        async def main() -> None:
            box = Outbox(limit=10)
            old, new = command("MOTOR:1,1,1,1"), command("MOTOR:2,2,1,1")
            box.put(old)
            box.put(new)
            assert outcome(old) is Outcome.SUPERSEDED and box.superseded == 1
            assert box.pop() is new and box.pop() is None

        vclock.run(main())

    def test_stop_replaces_queued_motor_and_heartbeat(self) -> None:
        """A queued MOTOR is obsolete once STOP is asked for."""

        async def main() -> None:
            box = Outbox(limit=10)
            motor, stop = command("MOTOR:9,9,1,1"), command("STOP")
            box.put(motor)
            box.put(stop)
            assert outcome(motor) is Outcome.SUPERSEDED
            assert [c.payload for c in iter(box.pop, None)] == ["STOP"]

        vclock.run(main())

    def test_cosmetic_commands_past_the_limit_drop_oldest_first(self) -> None:
        """With limit 10, the 11th and 12th LED commands drop the two oldest, counted."""

        async def main() -> None:
            box = Outbox(limit=10)
            cmds = [command(f"SERVO:{i}") for i in range(12)]
            for c in cmds:
                box.put(c)
            assert [outcome(c) for c in cmds[:2]] == [Outcome.DROPPED] * 2
            assert box.dropped == 2 and len(box) == 10
            assert box.pop() is cmds[2]

        vclock.run(main())

    def test_motor_is_never_dropped_however_full_the_queue(self) -> None:
        """Critical commands do not count against the limit."""

        async def main() -> None:
            box = Outbox(limit=1)
            motor = command("MOTOR:5,5,1,1")
            box.put(motor)
            for i in range(5):
                box.put(command(f"SERVO:{i}"))
            assert box.pop() is motor

        vclock.run(main())

    def test_a_heartbeat_is_not_queued_behind_a_motor(self) -> None:
        """MOTOR feeds the deadman too: a HB next to a queued MOTOR is superseded."""

        async def main() -> None:
            box = Outbox(limit=10)
            box.put(command("MOTOR:5,5,1,1"))
            hb = command("HB")
            box.put(hb)
            assert outcome(hb) is Outcome.SUPERSEDED

        vclock.run(main())

    def test_clear_settles_everything_with_the_outcome(self) -> None:
        """On link down every queued command ends LINK_DOWN and the outbox is empty."""

        async def main() -> None:
            box = Outbox(limit=10)
            cmds = [command("STOP"), command("LED_IDLE")]
            for c in cmds:
                box.put(c)
            box.clear(Outcome.LINK_DOWN)
            results = [delivery(c) for c in cmds]
            assert {r.outcome for r in results} == {Outcome.LINK_DOWN}
            assert len(box) == 0

        vclock.run(main())

    def test_a_command_nobody_waits_for_settles_without_a_delivery(self) -> None:
        """Wheel commands and heartbeats have no future: replacing them just drops them."""

        async def main() -> None:
            box = Outbox(limit=10)
            box.put(Command("MOTOR:1,1,1,1", None))
            newer = command("MOTOR:2,2,1,1")
            box.put(newer)
            box.put(Command("HB", None))
            assert box.superseded == 1
            assert box.pop() is newer and box.pop() is None

        vclock.run(main())
