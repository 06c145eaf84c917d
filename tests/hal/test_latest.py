"""LatestValue: the newest reading, waiters for the next one, and listeners called on publish."""

from __future__ import annotations

import asyncio

import pytest

from hal.latest import LatestValue
from sim import vclock


class TestLatestValue:
    def test_a_waiter_gets_the_next_value_not_the_current_one(self) -> None:
        async def main() -> int:
            value: LatestValue[int] = LatestValue()
            value.publish(1)
            waiter = asyncio.ensure_future(value.next())
            await asyncio.sleep(0)
            value.publish(2)
            return await waiter

        assert vclock.run(main()) == 2

    def test_a_listener_is_called_with_each_value_as_it_is_published(self) -> None:
        """No task runs in between: the listener has seen the value when publish returns."""
        value: LatestValue[int] = LatestValue()
        seen: list[int] = []
        value.listen(seen.append)
        value.publish(1)
        assert seen == [1]
        value.publish(2)
        assert seen == [1, 2]
        assert value.latest() == 2

    def test_a_stopped_listener_is_no_longer_called(self) -> None:
        value: LatestValue[int] = LatestValue()
        seen: list[int] = []
        stop = value.listen(seen.append)
        value.publish(1)
        stop()
        value.publish(2)
        assert seen == [1]

    def test_a_listener_that_raises_spoils_neither_the_others_nor_the_waiters(self) -> None:
        """The failure is logged; the next listener and the waiting task still get the value."""

        def broken(_value: int) -> None:
            raise RuntimeError("boom")

        async def main() -> tuple[int, list[int]]:
            value: LatestValue[int] = LatestValue()
            seen: list[int] = []
            value.listen(broken)
            value.listen(seen.append)
            waiter = asyncio.ensure_future(value.next())
            await asyncio.sleep(0)
            value.publish(7)
            value.publish(8)
            return await waiter, seen

        assert vclock.run(main()) == (7, [7, 8])

    def test_fail_wakes_the_waiters_with_the_error(self) -> None:
        async def main() -> None:
            value: LatestValue[int] = LatestValue()
            waiter = asyncio.ensure_future(value.next())
            await asyncio.sleep(0)
            value.fail(ConnectionError("gone"))
            await waiter

        with pytest.raises(ConnectionError):
            vclock.run(main())
